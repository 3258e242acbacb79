"""The one module that talks to SUMO: libsumo in-process (the default), traci over a socket to a `sumo` process,
or traci + sumo-gui when a window is asked for.

Episodes start from warm traffic states (`warm_states`: three pools that never share a state, cached on disk);
each reset reloads one of them with a fresh `--seed`, so arrivals, desired speeds of new vehicles and driver
imperfection differ between episode seeds while one seed always gives the same traffic.
(`simulation.loadState` is not used: it does not restore SUMO's random number
generators, so it is not reproducible; a reload with `--load-state` is, and takes about 10 ms.)
"""

from __future__ import annotations

import contextlib
import io
import itertools
import logging
import math
import operator
import os
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

import numpy as np

from sumo_rail.config import ScenarioConfig
from sumo_rail.datasets import describe
from sumo_rail.sim import gui as sumo_gui
from sumo_rail.sim import network
from sumo_rail.sim.vehicles import EgoState, Neighbours, PeriodReport
from sumo_rail.sim.warm_states import WARM_STATE_POOLS as WARM_STATE_POOLS  # importable from here, as before
from sumo_rail.sim.warm_states import WarmStates

log = logging.getLogger(__name__)

EGO_ID = "ego"
LANE_CHANGE_MODE_TRACI_ONLY_SAFE = 0b1100000000
"""No autonomous lane changes; TraCI requests respect other drivers' gaps, without speed adaptation."""
_ACTIVE_LIBSUMO: Simulation | None = None
ENTRY_WAIT_S = 30.0
"""Longest wait of an ego for room at its start place at a reset [s] (simulated time)."""
REACTION_S = 1.0
"""Reaction time in `Simulation.place_ego`'s safety margins [s] (traffic acts every 0.5 s, with tau up to 1.2 s)."""
PLACE_MARGIN_M = 5.0
"""Extra distance in `Simulation.place_ego`'s safety margins [m]."""
TRANSPORTS = ("auto", "libsumo", "traci")
"""How SUMO is driven: libsumo (SUMO linked into this process), traci (a SUMO process, over a socket; the same
episodes, slower), or auto: libsumo unless another simulation of this process holds it, then traci."""
_TRACI_LABELS = itertools.count()
"""traci connections are named: each simulation over traci has its own, so several can run in one process."""


class SimulationError(RuntimeError):
    """SUMO could not do what was asked (message is one sentence)."""


class Simulation:
    """One SUMO instance for the ego's episodes on one scenario, driven by `transport` (`TRANSPORTS`); `gui` implies
    traci, and sumo-gui then follows the ego, waiting `gui_delay_ms` [ms] of wall time per step."""

    def __init__(self, scenario: ScenarioConfig, context_radius_m: float, gui: bool = False,
                 transport: str = "libsumo", gui_delay_ms: float = 100.0) -> None:
        global _ACTIVE_LIBSUMO
        if transport not in TRANSPORTS:
            raise ValueError(f"transport must be one of {', '.join(TRANSPORTS)}, got {transport!r}")
        if transport == "auto":
            transport = "libsumo" if _ACTIVE_LIBSUMO is None else "traci"
            if transport == "traci" and not gui:
                warnings.warn("libsumo runs one simulation per process and another one holds it: this one runs over "
                              "traci (the same episodes, slower)", stacklevel=3)
        self.transport = "traci" if gui else transport
        if self.transport == "libsumo" and _ACTIVE_LIBSUMO is not None:
            raise SimulationError(
                "libsumo runs one simulation per process and one is already open here; close it first, run the "
                "second one in another process, or use transport='traci' (a SUMO process each, slower)")
        self.scenario = scenario
        self.context_radius_m = context_radius_m
        self.gui = gui
        self.gui_delay_ms = gui_delay_ms
        self._built = network.build(scenario)
        self._client = _load_api(self.transport)
        self._label = f"sumo_rail_{next(_TRACI_LABELS)}"
        self._constants = tc = _load_constants()
        self._context_variables = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_LANEPOSITION, tc.VAR_LENGTH,
                                   tc.VAR_WIDTH, tc.VAR_LANE_INDEX)
        self._context_fields = operator.itemgetter(*self._context_variables)
        self._start(["--seed", str(scenario.traffic_seed)])
        self._warm_states = WarmStates(scenario, self._built, self._options()[4:], self._run_warm_up)
        self._running = True
        if self.transport == "libsumo":
            _ACTIVE_LIBSUMO = self

    @property
    def time_s(self) -> float:
        """Current simulation time [s]."""
        return self._api.simulation.getTime()

    @property
    def snapshot_count(self) -> int:
        """Warm states in each pool."""
        return self.scenario.snapshots

    def _options(self) -> list[str]:
        """Every SUMO option that shapes the simulation, explicitly."""
        s = self.scenario
        return [
            "--net-file", str(self._built.net_file),
            "--route-files", str(self._built.routes_file),
            "--step-length", repr(s.step_length_s),
            "--lanechange.duration", repr(s.lane_change_duration_s),
            "--time-to-teleport", repr(s.teleport_time_s),
            "--collision.action", "remove",
            "--collision.check-junctions", "true",
            "--collision.mingap-factor", repr(s.collision_min_gap_factor),
            "--random", "false",
            "--save-state.rng", "false",
            "--save-state.precision", "6",
            "--xml-validation", "never",
            "--no-step-log", "true",
            "--no-warnings", "true",
            "--duration-log.disable", "true",
        ]

    def _gui_options(self) -> list[str]:
        """sumo-gui runs without waiting for its play button and closes at the end, after a start and after each
        load (a load resets the options, and a GUI loaded without --start waits for its play button, so the
        client would block in its next command). Its own --delay is 0: under TraCI it does not pace the steps the
        client asks for, so `PacedApi` does."""
        if not self.gui:
            return []
        return ["--start", "true", "--quit-on-end", "true", "--delay", "0",
                "--window-size", sumo_gui.WINDOW_SIZE, "--gui-settings-file", str(sumo_gui.settings_file())]

    def _start(self, extra: list[str]) -> None:
        binary = network.sumo_binary("sumo-gui" if self.gui else "sumo")
        gui_options = self._gui_options()
        from traci.exceptions import FatalTraCIError

        if self.gui and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise SimulationError("sumo-gui needs a display and neither DISPLAY nor WAYLAND_DISPLAY is set; "
                                  "run headless instead (--gui-off; in Python, render_mode None or 'rgb_array')")
        retries = {"numRetries": 3} if self.gui else {}
        command = [binary, *self._options(), *gui_options, *extra]
        try:
            if self.transport == "traci":
                with contextlib.redirect_stdout(io.StringIO()):  # traci prints each retry while SUMO starts up
                    self._client.start(command, label=self._label, doSwitch=False, **retries)
                api = self._client.getConnection(self._label)
            else:
                self._client.start(command)
                api = self._client
        except self._client.TraCIException as error:  # type: ignore[attr-defined]
            raise SimulationError(f"SUMO failed to start: {describe(error)}") from error
        except FatalTraCIError as error:
            raise SimulationError(f"sumo-gui did not start (is a display available?): {describe(error)}") from error
        self._api = sumo_gui.PacedApi(api, self.gui_delay_ms / 1000.0) if self.gui else api

    def _load(self, extra: list[str]) -> None:
        try:
            self._api.load([*self._options(), *self._gui_options(), *extra])
        except self._client.TraCIException as error:  # type: ignore[attr-defined]
            where = next((line.strip() for line in str(error).splitlines() if "In file" in line), "")
            raise SimulationError(f"SUMO failed to load the warm state: {describe(error)}"
                                  + (f" ({where})" if where else "")) from error

    def _pool(self, pool: str) -> list[Path]:
        """Paths of a pool's warm states, built on first use."""
        return self._warm_states.pool(pool)

    def _run_warm_up(self, traffic_seed: int, paths: list[Path]) -> None:
        """Run the warm-up of `traffic_seed` and save its states to `paths` (each written aside, then renamed)."""
        with sumo_gui.unpaced(self._api):  # sumo-gui's pace is for episodes, not for building warm states
            self._load(["--seed", str(traffic_seed)])
            api = self._api
            api.simulationStep(self.scenario.warmup_s)
            for k, path in enumerate(paths):
                if k:
                    api.simulationStep(api.simulation.getTime() + self.scenario.snapshot_interval_s)
                temporary = path.with_suffix(f".{os.getpid()}.tmp")
                api.simulation.saveState(str(temporary))
                os.replace(temporary, path)
        log.info("saved %d warm states in %s", len(paths), paths[0].parent)

    def reset(self, snapshot: int, sumo_seed: int, ego_lane: int, ego_position_m: float, pool: str = "train") -> None:
        """Reload warm state `snapshot` of `pool` with SUMO seed `sumo_seed` and insert the ego; steps until it
        is in."""
        self.reset_egos(snapshot, sumo_seed, [(EGO_ID, ego_lane, ego_position_m)], pool)

    def reset_egos(self, snapshot: int, sumo_seed: int, egos: Sequence[tuple[str, int, float]],
                   pool: str = "train") -> list[str]:
        """`reset` with several egos: queue each (vehicle id, lane, front position [m]) in this order, then step
        until all are in (an ego drives on as soon as it is in). SUMO tries no other vehicle in a lane once one
        fails there in a step, so egos still waiting take turns at being tried first. An ego not on the road after
        `ENTRY_WAIT_S` (no room at its place all along, or gone already) sits the episode out: returns those ids,
        in order (SimulationError when none of the egos is on the road)."""
        self._require_running()
        try:
            self._load(["--load-state", str(self._pool(pool)[snapshot]), "--seed", str(sumo_seed)])
        except SimulationError as error:  # a cached file damaged since the start: rebuild what is damaged, once
            log.warning("%s; checking the cached network and warm states", error)
            network.build(self.scenario)
            self._warm_states.forget()
            self._load(["--load-state", str(self._pool(pool)[snapshot]), "--seed", str(sumo_seed)])
        for ego in egos:
            self._insert(*ego)
        pending = list(egos)
        for _ in range(round(ENTRY_WAIT_S / self.scenario.step_length_s)):
            self._api.simulationStep()
            departed = set(self._api.simulation.getDepartedIDList())
            pending = [ego for ego in pending if ego[0] not in departed]
            if not pending:
                break
            if len(pending) > 1:
                for vehicle, _, _ in pending:
                    self._api.vehicle.remove(vehicle)
                pending = pending[1:] + pending[:1]
                for ego in pending:
                    self._insert(*ego)
        for vehicle, _, _ in pending:
            self._api.vehicle.remove(vehicle)  # out of the insertion queue
        on_road = set(self._api.vehicle.getIDList()) if len(egos) > 1 else set()
        absent = pending if len(egos) == 1 else [ego for ego in egos if ego[0] not in on_road]
        if len(absent) == len(egos):
            vehicle, lane, position_m = absent[0]
            who = "the ego" if len(egos) == 1 else f"no ego could enter the road: ego {vehicle}"
            raise SimulationError(f"{who} could not enter lane {lane} at {position_m:.1f} m within {ENTRY_WAIT_S:g} s: "
                                  f"traffic is too dense there (scenario.flow_veh_per_h is "
                                  f"{self.scenario.flow_veh_per_h:g} veh/h; a lower flow leaves room)")
        for vehicle, lane, position_m in pending:  # said only when the others drive on (the error says it otherwise)
            log.warning("ego %s could not enter lane %d at %.1f m within %g s", vehicle, lane, position_m,
                        ENTRY_WAIT_S)
        if self.gui:
            self._follow_ego(next(ego[0] for ego in egos if ego not in absent))
        return [vehicle for vehicle, _, _ in absent]

    @property
    def ego_length_m(self) -> float:
        """Length of an ego vehicle [m]."""
        return self._api.vehicletype.getLength(network.EGO_TYPE)

    def place_ego(self, vehicle: str, lane: int, position_m: float, max_speed_mps: float) -> bool:
        """Put a new ego on the road at once, between two steps, in `lane` with its front at `position_m` [m], at
        the highest speed up to `max_speed_mps` that is safe there; False (and nothing placed) when none is.

        SUMO inserts a vehicle added now only at the next step; `vehicle.moveTo` forces it in at once, skipping
        SUMO's insertion checks, so they are made here. No vehicle may overlap the place (vehicles changing into or
        out of `lane` count as in it). The gap to the leader (beyond the ego's minimum gap) must exceed what the ego
        covers in `REACTION_S` plus `PLACE_MARGIN_M`, and that plus the ego's braking distance at its type's
        deceleration minus the leader's at its own; the follower's gap to the ego must exceed SUMO's secure gap for
        the follower (`getSecureGap`; for an ego follower, whose ACC model's is smaller, the same braking-distance
        difference) plus what it covers in `REACTION_S` and `PLACE_MARGIN_M`.
        """
        api = self._api.vehicle
        ego_type = self._api.vehicletype
        ego_length_m, ego_min_gap_m = self.ego_length_m, ego_type.getMinGap(network.EGO_TYPE)
        ego_decel_mps2 = ego_type.getDecel(network.EGO_TYPE)
        ahead, behind = [], []
        for other, front_m, rear_m in self._lane_occupants(lane):
            if rear_m >= position_m:
                ahead.append((rear_m, other))
            elif front_m <= position_m - ego_length_m:
                behind.append((front_m, other))
            else:
                return False
        speed_mps = max_speed_mps
        if ahead:
            rear_m, leader = min(ahead)
            leader_speed = api.getSpeed(leader)
            gap_m = rear_m - position_m - ego_min_gap_m - PLACE_MARGIN_M
            if gap_m <= 0:
                return False
            # the largest v with gap >= v REACTION_S and gap >= v^2 / 2b - v_l^2 / 2b_l + v REACTION_S
            room_m = gap_m + leader_speed**2 / (2 * api.getDecel(leader))
            braking_mps = ego_decel_mps2 * (math.sqrt(REACTION_S**2 + 2 * room_m / ego_decel_mps2) - REACTION_S)
            speed_mps = min(speed_mps, gap_m / REACTION_S, braking_mps)
        if behind:
            front_m, follower = max(behind)
            follower_speed = api.getSpeed(follower)
            braking_m = follower_speed**2 / (2 * api.getDecel(follower)) - speed_mps**2 / (2 * ego_decel_mps2)
            secure_m = max(api.getSecureGap(follower, follower_speed, speed_mps, ego_decel_mps2), braking_m)
            gap_m = position_m - ego_length_m - front_m - api.getMinGap(follower)
            if gap_m < secure_m + follower_speed * REACTION_S + PLACE_MARGIN_M:
                return False
        api.add(vehicle, network.ROUTE_ID, typeID=network.EGO_TYPE, depart="now", departLane=str(lane),
                departPos=repr(position_m), departSpeed=repr(speed_mps))
        api.moveTo(vehicle, f"{network.EDGE_ID}_{lane}", position_m)
        api.setLaneChangeMode(vehicle, LANE_CHANGE_MODE_TRACI_ONLY_SAFE)
        return True

    def _lane_occupants(self, lane: int) -> list[tuple[str, float, float]]:
        """(id, front, rear) [m along the road] of every vehicle in `lane` or changing into or out of it (off its
        lane's centre line)."""
        lanes, api = self._api.lane, self._api.vehicle
        vehicles = list(lanes.getLastStepVehicleIDs(f"{network.EDGE_ID}_{lane}"))
        for neighbour in (lane - 1, lane + 1):
            if 0 <= neighbour < self.scenario.lanes:
                vehicles += [vehicle for vehicle in lanes.getLastStepVehicleIDs(f"{network.EDGE_ID}_{neighbour}")
                             if api.getLateralLanePosition(vehicle) != 0.0]
        occupants = []
        for vehicle in vehicles:
            front_m = api.getLanePosition(vehicle)
            occupants.append((vehicle, front_m, front_m - api.getLength(vehicle)))
        return occupants

    def _insert(self, vehicle: str, lane: int, position_m: float) -> None:
        """Queue an ego for insertion now in `lane` with its front at `position_m` [m], at the highest safe speed."""
        self._api.vehicle.add(vehicle, network.ROUTE_ID, typeID=network.EGO_TYPE, depart="now",
                              departLane=str(lane), departPos=repr(position_m), departSpeed="max")
        self._api.vehicle.setLaneChangeMode(vehicle, LANE_CHANGE_MODE_TRACI_ONLY_SAFE)

    def _follow_ego(self, vehicle: str = EGO_ID) -> None:
        """Point sumo-gui's view at an ego: tracked, zoomed to its surroundings, drawn in red."""
        sumo_gui.follow(self._api, vehicle)

    def screenshot(self, path: Path, width_px: int = 1280, height_px: int = 800) -> None:
        """Save sumo-gui's view to `path` (PNG) when the next step is drawn (sumo-gui only)."""
        if not self.gui:
            raise SimulationError("screenshots need sumo-gui (render_mode='human')")
        self._api.gui.screenshot(sumo_gui.VIEW, str(path), width_px, height_px)

    def set_cruise_speed(self, speed_mps: float, vehicle: str = EGO_ID) -> None:
        """Set an ego's cruise set-point [m/s]; SUMO's ACC model tracks it within safe gaps.

        The set-point is the ego's desired speed, speed factor x speed limit. (Lowering the vehicle's maximum
        speed instead would be a hard cap that SUMO enforces at emergency deceleration, 9 m/s^2; a lower speed
        factor is reached at the ego type's comfortable deceleration.)
        """
        self._api.vehicle.setSpeedFactor(vehicle, speed_mps / self.scenario.speed_limit_mps)

    def request_lane_change(self, lane: int, duration_s: float, vehicle: str = EGO_ID) -> None:
        """Ask SUMO to move an ego to `lane` when safe within `duration_s`; unsafe changes wait, never forced."""
        self._api.vehicle.changeLane(vehicle, lane, duration_s)

    def advance(self, steps: int) -> PeriodReport:
        """Run `steps` SUMO steps, watching the ego for collisions, arrival, braking and teleports.

        Three calls a step: the step, the teleport count and the ego's acceleration. The ego is gone (collided,
        and so removed, or arrived) exactly when asking for its acceleration fails; only then are the step's
        collision and arrival lists read, collision first.
        """
        api = self._api
        step, simulation, acceleration = api.simulationStep, api.simulation, api.vehicle.getAcceleration
        starting_teleports = simulation.getStartingTeleportNumber
        collided = left = ego_teleported = False
        min_accel = math.inf
        teleports = 0
        for _ in range(steps):
            step()
            if starting_teleports():
                starting = simulation.getStartingTeleportIDList()
                teleports += len(starting)
                ego_teleported |= EGO_ID in starting
            try:
                accel = acceleration(EGO_ID)
            except self._client.TraCIException:  # type: ignore[attr-defined]
                collided, left = self._why_gone(EGO_ID)
                break
            if accel < min_accel:
                min_accel = accel
        return PeriodReport(collided, left, ego_teleported, _lowest(min_accel), teleports)

    def advance_egos(self, steps: int, vehicles: Sequence[str]) -> list[PeriodReport]:
        """`advance` for several egos on one road: run `steps` SUMO steps, watching each ego of `vehicles` as
        `advance` watches the one ego, until it is gone; the steps go on while any of them is on the road. One
        report per ego, in order; an ego that is gone has the time it went (`left_at_s`) and the teleports until
        then."""
        api = self._api
        step, simulation, acceleration = api.simulationStep, api.simulation, api.vehicle.getAcceleration
        starting_teleports = simulation.getStartingTeleportNumber
        on_road = list(vehicles)
        min_accel = dict.fromkeys(on_road, math.inf)
        teleported: set[str] = set()
        teleports = 0
        gone: dict[str, PeriodReport] = {}
        for _ in range(steps):
            step()
            if starting_teleports():
                starting = simulation.getStartingTeleportIDList()
                teleports += len(starting)
                teleported.update(starting)
            for vehicle in on_road:
                try:
                    accel = acceleration(vehicle)
                except self._client.TraCIException:  # type: ignore[attr-defined]
                    collided, left = self._why_gone(vehicle)
                    gone[vehicle] = PeriodReport(collided, left, vehicle in teleported, _lowest(min_accel[vehicle]),
                                                 teleports, simulation.getTime())
                    continue
                if accel < min_accel[vehicle]:
                    min_accel[vehicle] = accel
            if gone.keys() & on_road:
                on_road = [vehicle for vehicle in on_road if vehicle not in gone]
                if not on_road:
                    break
        return [gone.get(vehicle) or PeriodReport(False, False, vehicle in teleported, _lowest(min_accel[vehicle]),
                                                  teleports) for vehicle in vehicles]

    def _why_gone(self, vehicle: str) -> tuple[bool, bool]:
        """(collided, arrived) for an ego SUMO no longer answers about, after a step: collided (and so removed)
        or arrived at the end of the road; SimulationError if neither."""
        simulation = self._api.simulation
        collided = vehicle in simulation.getCollidingVehiclesIDList()
        if not (collided or vehicle in simulation.getArrivedIDList()):
            raise SimulationError(f"SUMO lost ego {vehicle} without a collision or an arrival")
        return collided, not collided

    def observe(self, vehicle: str = EGO_ID) -> tuple[EgoState, Neighbours]:
        """An ego and its neighbours (other egos included) within the context radius, from one context
        subscription.

        Headings are SUMO's angles (degrees, 0 = north, clockwise) as math headings (radians, 0 = +x,
        counter-clockwise): radians(90 - angle). The subscription is made and dropped at each decision: SUMO
        answers a new subscription at once, and a standing one would be recomputed at every step of the decision
        period for nothing.
        """
        tc, fields = self._constants, self._context_fields
        api = self._api.vehicle
        api.subscribeContext(vehicle, tc.CMD_GET_VEHICLE_VARIABLE, self.context_radius_m, self._context_variables)
        results = api.getContextSubscriptionResults(vehicle)
        api.unsubscribeContext(vehicle, tc.CMD_GET_VEHICLE_VARIABLE, self.context_radius_m)
        (ego_x, ego_y), angle, speed, lane_position, length, width, lane = fields(results.pop(vehicle))
        ego_state = EgoState(ego_x, ego_y, math.radians(90.0 - angle), speed, lane, lane_position,
                             api.getLateralLanePosition(vehicle), length, width)
        flat: list[float] = []
        extend, radians = flat.extend, math.radians
        for (x, y), angle, speed, lane_position, length, width, lane in map(fields, results.values()):
            extend((x, y, radians(90.0 - angle), speed, lane_position, length, width, lane))
        rows = np.array(flat, dtype=np.float64).reshape(len(results), 8)
        neighbours = Neighbours(ids=tuple(results), front_xy=rows[:, :2], heading_rad=rows[:, 2],
                                speed_mps=rows[:, 3], lane_position_m=rows[:, 4], length_m=rows[:, 5],
                                width_m=rows[:, 6], lane=rows[:, 7].astype(np.int64))
        return ego_state, neighbours

    def vehicle_types(self, ids: tuple[str, ...]) -> list[str]:
        """SUMO vehicle type of each vehicle in `ids` (e.g. "car", "truck"), for drawing."""
        get_type = self._api.vehicle.getTypeID
        return [get_type(vehicle) for vehicle in ids]

    def road_edges(self) -> np.ndarray:
        """The road's outer edges as line segments [m], shape (S, 2, 2): right edge first, then left."""
        lane = self._api.lane
        lanes = self.scenario.lanes
        right_id = f"{network.EDGE_ID}_0"
        right = network.offset_polyline(np.array(lane.getShape(right_id)), -lane.getWidth(right_id) / 2)
        left_id = f"{network.EDGE_ID}_{lanes - 1}"
        left = network.offset_polyline(np.array(lane.getShape(left_id)), lane.getWidth(left_id) / 2)
        return np.concatenate([network.segments(right), network.segments(left)])

    def close(self) -> None:
        """End SUMO; calling it again is harmless."""
        global _ACTIVE_LIBSUMO
        if not self._running:
            return
        self._running = False
        if _ACTIVE_LIBSUMO is self:
            _ACTIVE_LIBSUMO = None
        try:
            self._api.close()
        except Exception as error:
            log.debug("ignored error while closing SUMO: %s", error)

    def _require_running(self) -> None:
        if not self._running:
            raise SimulationError("this simulation is closed; create a new one")


def _lowest(acceleration_mps2: float) -> float:
    """A period's lowest acceleration [m/s^2], 0 when none was read."""
    return acceleration_mps2 if acceleration_mps2 < math.inf else 0.0


def _load_api(transport: str) -> ModuleType:
    if transport == "traci":
        # traci's own socket client: a plain `import traci` gives libsumo once LIBSUMO_AS_TRACI is set (below)
        import traci.main

        return traci.main
    os.environ.setdefault("LIBSUMO_AS_TRACI", "quiet")
    import libsumo

    return libsumo


def _load_constants() -> ModuleType:
    import traci.constants

    return traci.constants
