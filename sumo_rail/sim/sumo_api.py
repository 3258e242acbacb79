"""What every part of the simulation shares about SUMO's API: its error, the transports, the ego's id and lane-change
mode, and loading libsumo or traci (imported only here and when a simulation starts)."""

from __future__ import annotations

import os
from collections.abc import Callable
from types import ModuleType
from typing import Any

EGO_ID = "ego"
"""The single ego's vehicle id."""
LANE_CHANGE_MODE_TRACI_ONLY_SAFE = 0b1100000000
"""No autonomous lane changes; TraCI requests respect other drivers' gaps, without speed adaptation."""
LANE_CHANGE_MODE_ZIP_MERGE = 0b0100000000
"""No autonomous lane changes; TraCI requests only avoid immediate collisions (others brake for the ego)."""
TRANSPORTS = ("auto", "libsumo", "traci")
"""How SUMO is driven: libsumo (SUMO linked into this process), traci (a SUMO process, over a socket; the same
episodes, slower), or auto: libsumo unless another simulation of this process holds it, then traci."""


class SimulationError(RuntimeError):
    """SUMO could not do what was asked (message is one sentence)."""


def load_api(transport: str) -> ModuleType:
    """libsumo, or traci's own socket client for "traci"."""
    if transport == "traci":
        # traci's own socket client: a plain `import traci` gives libsumo once LIBSUMO_AS_TRACI is set (below)
        import traci.main

        return traci.main
    os.environ.setdefault("LIBSUMO_AS_TRACI", "quiet")
    import libsumo

    return libsumo


def load_constants() -> ModuleType:
    """TraCI's constants (variable ids)."""
    import traci.constants

    return traci.constants


def period_calls(api: Any) -> tuple[Callable[[], Any], Callable[[], int], Callable[[str], float]]:
    """(one step, the number of vehicles that started a teleport in it, a vehicle's acceleration [m/s^2]): the calls of
    a decision period's every step. With libsumo, its compiled functions themselves: its Python wrappers add a call
    each, and its step's wrapper runs traci's step listeners, which this project never adds."""
    compiled = getattr(api, "_libsumo", None)
    if compiled is None:
        return api.simulationStep, api.simulation.getStartingTeleportNumber, api.vehicle.getAcceleration
    return compiled.simulation_step, compiled.simulation_getStartingTeleportNumber, compiled.vehicle_getAcceleration
