"""What every part of the simulation shares about SUMO's API: its error, the transports, the ego's id and lane-change
mode, and loading libsumo or traci (imported only here and when a simulation starts)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from collections.abc import Callable
from types import ModuleType
from typing import IO, Any, NamedTuple

EGO_ID = "ego"
"""The single ego's vehicle id."""
LANE_CHANGE_MODE_TRACI_ONLY_SAFE = 0b1100000000
"""No autonomous lane changes; TraCI requests respect other drivers' gaps, without speed adaptation."""
LANE_CHANGE_MODE_ZIP_MERGE = 0b0100000000
"""No autonomous lane changes; TraCI requests only avoid immediate collisions (others brake for the ego)."""
SPEED_MODE_COMMANDED_ACCELERATION = 0b11001
"""An ego driven by commanded accelerations: SUMO regards the safe speed (its emergency brake), right of way and red
lights, not the bound on deceleration (the interface's range bounds it; the ego's acceleration capability is set
to the range's highest)."""
INVALID_VALUE = -1073741824.0
"""What SUMO answers for a value it does not have (libsumo.INVALID_DOUBLE_VALUE): the acceleration of a vehicle still
waiting to be inserted, for one."""
TRANSPORTS = ("auto", "libsumo", "traci")
"""How SUMO is driven: libsumo (SUMO linked into this process), traci (a SUMO process, over a socket; the same
episodes, slower), or auto: libsumo unless another simulation of this process holds it, then traci."""


class SimulationError(RuntimeError):
    """SUMO could not do what was asked (message is one sentence)."""


def load_api(transport: str) -> ModuleType:
    """libsumo, or traci's own socket client for "traci"."""
    if transport == "traci":
        # traci's own socket client: a plain `import traci` gives libsumo once LIBSUMO_AS_TRACI is set (below), and
        # then even traci.main's exception names are libsumo's, while the socket client raises its own: the client
        # is traci.main with the exceptions its connection raises, or an error over traci in a process that loaded
        # libsumo first (the "auto" fallback) would not be caught
        import traci.connection
        import traci.main

        client = ModuleType("traci_socket_client")
        client.__dict__.update(vars(traci.main))
        client.TraCIException = traci.connection.TraCIException  # type: ignore[attr-defined]
        client.FatalTraCIError = traci.connection.FatalTraCIError  # type: ignore[attr-defined]
        return client
    os.environ.setdefault("LIBSUMO_AS_TRACI", "quiet")
    import libsumo

    return libsumo


TRACI_RETRIES = 60
"""Attempts to connect to a starting SUMO, a second apart (traci.start's: a large network takes long to load)."""
ANSWERED_ERROR = b"Error: Answered with error to command"
"""How SUMO's stderr begins the line of each TraCI command it answers with an error (libsumo writes none): the client
raises the error itself, and asking for a vehicle that has left is how the stepping learns that an ego is gone."""


def start_traci(client: ModuleType, command: list[str], label: str, retries: int) -> Any:
    """SUMO at `command` over TraCI as the connection `label` of `client` (`load_api`'s), as traci.start makes it, but
    SUMO's stderr is passed on to this process's without its `ANSWERED_ERROR` lines."""
    port = client.getFreeSocketPort()
    process = subprocess.Popen([*command, "--remote-port", str(port)], stderr=subprocess.PIPE)
    threading.Thread(target=_pass_on, args=(process.stderr,), name="sumo-stderr", daemon=True).start()
    client.init(port, retries, "localhost", label, process, doSwitch=False)
    return client.getConnection(label)


def _pass_on(stream: IO[bytes]) -> None:
    """Copy SUMO's stderr `stream` to this process's, line by line, but the `ANSWERED_ERROR` lines."""
    with stream:
        for line in stream:
            if not line.startswith(ANSWERED_ERROR):
                sys.stderr.write(line.decode(errors="replace"))
                sys.stderr.flush()


def load_constants() -> ModuleType:
    """TraCI's constants (variable ids)."""
    import traci.constants

    return traci.constants


class DecisionCalls(NamedTuple):
    """SUMO's calls made at every decision or every step of its period."""

    step: Callable[[], Any]
    starting_teleports: Callable[[], int]
    """The number of vehicles that started a teleport in the last step."""
    acceleration: Callable[[str], float]
    """A vehicle's acceleration [m/s^2]."""
    time_s: Callable[[], float]
    subscribe_context: Callable[[str, int, float, Any], None]
    context_results: Callable[[str], dict[str, dict[int, Any]]]
    unsubscribe_context: Callable[[str, int, float], None]
    lateral_position: Callable[[str], float]
    """A vehicle's lateral position in its lane [m]."""
    move_to_xy: Callable[..., None]
    """moveToXY (a replayed vehicle's placement, every step: `sumo_rail.sim.replay`)."""
    position: Callable[[str], tuple[float, float]]
    """A vehicle's x, y [m] (the replay's ego, every step)."""
    vehicle_ids: Callable[[], tuple[str, ...]]
    """The vehicles on the road (the replay's, every step)."""
    add: Callable[[str, str, str, str, str, str, str], None]
    """A vehicle added: id, route, type, depart, depart lane, position and speed (the replay's entries)."""
    set_length: Callable[[str, float], None]
    set_width: Callable[[str, float], None]
    set_speed_mode: Callable[[str, int], None]
    set_lane_change_mode: Callable[[str, int], None]


def decision_calls(api: Any) -> DecisionCalls:
    """The calls of every decision. With libsumo, its compiled functions themselves: its Python wrappers add a call
    each (about 1 k instructions), subscribeContext's checks its arguments for None and its step's runs traci's step
    listeners, which this project never adds."""
    compiled = getattr(api, "_libsumo", None)
    if compiled is None:
        vehicle, simulation = api.vehicle, api.simulation
        return DecisionCalls(api.simulationStep, simulation.getStartingTeleportNumber, vehicle.getAcceleration,
                             simulation.getTime, vehicle.subscribeContext, vehicle.getContextSubscriptionResults,
                             vehicle.unsubscribeContext, vehicle.getLateralLanePosition, vehicle.moveToXY,
                             vehicle.getPosition, vehicle.getIDList, vehicle.add, vehicle.setLength, vehicle.setWidth,
                             vehicle.setSpeedMode, vehicle.setLaneChangeMode)
    return DecisionCalls(compiled.simulation_step, compiled.simulation_getStartingTeleportNumber,
                         compiled.vehicle_getAcceleration, compiled.simulation_getTime,
                         compiled.vehicle_subscribeContext, compiled.vehicle_getContextSubscriptionResults,
                         compiled.vehicle_unsubscribeContext, compiled.vehicle_getLateralLanePosition,
                         compiled.vehicle_moveToXY, compiled.vehicle_getPosition, compiled.vehicle_getIDList,
                         compiled.vehicle_add, compiled.vehicle_setLength, compiled.vehicle_setWidth,
                         compiled.vehicle_setSpeedMode, compiled.vehicle_setLaneChangeMode)
