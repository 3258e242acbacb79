"""One SUMO instance: libsumo in-process (the default), traci over a socket to a `sumo` process, or traci + sumo-gui
when a window is asked for; its parts are in `placement` (egos onto the road), `stepping` (decision periods) and
`sensing` (what egos see), and only these modules and `sumo_api` talk to SUMO.

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
import os
import warnings
import weakref
from collections.abc import Iterator, Sequence
from pathlib import Path

from sumo_rail.config import ScenarioConfig
from sumo_rail.datasets import describe, written_atomically
from sumo_rail.sim import gui as sumo_gui
from sumo_rail.sim import network
from sumo_rail.sim.commands import EgoCommands
from sumo_rail.sim.observers import Moment, Observer, Rows, VehicleRows, WatchedObserver
from sumo_rail.sim.placement import EgoPlacement
from sumo_rail.sim.road import RouteMap
from sumo_rail.sim.sensing import Sensing
from sumo_rail.sim.stepping import Stepping
from sumo_rail.sim.sumo_api import EGO_ID as EGO_ID  # importable from here, as before
from sumo_rail.sim.sumo_api import TRACI_RETRIES, decision_calls, load_api, load_constants, start_traci
from sumo_rail.sim.sumo_api import TRANSPORTS as TRANSPORTS
from sumo_rail.sim.sumo_api import SimulationError as SimulationError
from sumo_rail.sim.traffic_source import GeneratedTraffic, Step, TrafficSource
from sumo_rail.sim.vehicles import EgoState as EgoState
from sumo_rail.sim.vehicles import Neighbours as Neighbours
from sumo_rail.sim.warm_states import WARM_STATE_POOLS as WARM_STATE_POOLS
from sumo_rail.sim.warm_states import WarmStates

log = logging.getLogger(__name__)

_ACTIVE_LIBSUMO: Simulation | None = None
ENTRY_WAIT_S = 30.0
"""Longest wait of an ego for room at its start place at a reset [s] (simulated time)."""
_TRACI_LABELS = itertools.count()
"""traci connections are named: each simulation over traci has its own, so several can run in one process."""


class EgoCouldNotEnter(SimulationError):
    """No ego of a reset found room at its start place (the place may be drawn again)."""


class Simulation(EgoPlacement, Stepping, Sensing, EgoCommands):
    """One SUMO instance for the ego's episodes on one scenario, driven by `transport` (`TRANSPORTS`); `gui` implies
    traci, and sumo-gui then follows the ego, waiting `gui_delay_ms` [ms] of wall time per step. Its traffic is
    `traffic`'s (default `GeneratedTraffic`: the road's own flows, from warm states)."""

    def __init__(self, scenario: ScenarioConfig, context_radius_m: float, gui: bool = False,
                 transport: str = "libsumo", gui_delay_ms: float = 100.0,
                 traffic: TrafficSource | None = None) -> None:
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
        self.traffic = traffic or GeneratedTraffic()
        """Where the simulation's traffic comes from (`sumo_rail.sim.traffic_source`)."""
        self._built = self.traffic.network(scenario)
        self._observers: list[Observer] = []
        """Every-step observers (`watching`)."""
        self._rows: VehicleRows | None = None
        """The reader of every vehicle's rows since the last load (`vehicle_rows`)."""
        self.clock_offset_s = 0.0
        """`time_s` less SUMO's clock [s]: 0 but after `load_empty` at a time off SUMO's step grid."""
        self._client = load_api(self.transport)
        self._label = f"sumo_rail_{next(_TRACI_LABELS)}"
        self._constants = load_constants()
        self._context_setup()
        self._start(["--seed", str(scenario.traffic_seed)])
        self.route_map = RouteMap.from_sumo(self._api, self._built.ego_route, scenario.lanes)
        """The ego's route frame (`sumo_rail.sim.road`)."""
        self._zip_merging: set[str] = set()
        """Egos whose lane-change mode is `LANE_CHANGE_MODE_ZIP_MERGE`."""
        self._warm_states = WarmStates(scenario, self._built, self._options()[4:], self._run_warm_up)
        self._running = True
        if self.transport == "libsumo":
            _ACTIVE_LIBSUMO = self

    @property
    def time_s(self) -> float:
        """Current simulation time [s] (SUMO's clock plus `clock_offset_s`)."""
        return self._calls.time_s() + self.clock_offset_s

    @property
    def warm_state_count(self) -> int:
        """Warm states in each pool."""
        return self.scenario.snapshots

    def _options(self) -> list[str]:
        """Every SUMO option that shapes the simulation, explicitly."""
        return sumo_options(self.scenario, self._built)

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
        if self.gui and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise SimulationError("sumo-gui needs a display and neither DISPLAY nor WAYLAND_DISPLAY is set; "
                                  "run headless instead (--gui-off; in Python, render_mode None or 'rgb_array')")
        command = [binary, *self._options(), *gui_options, *extra]
        try:
            if self.transport == "traci":
                with contextlib.redirect_stdout(io.StringIO()):  # traci prints each retry while SUMO starts up
                    api = start_traci(self._client, command, self._label, 3 if self.gui else TRACI_RETRIES)
            else:
                self._client.start(command)
                api = self._client
        except (self._client.TraCIException, self._client.FatalTraCIError) as error:
            what = "sumo-gui did not start (is a display available?)" if self.gui else "SUMO failed to start"
            raise SimulationError(f"{what}: {describe(error)}") from error
        self._api = sumo_gui.PacedApi(api, self.gui_delay_ms / 1000.0) if self.gui else api
        self._calls = decision_calls(self._api)
        self._sumo_step: Step = self.traffic.connect(self._api, self.scenario.step_length_s,
                                                     self.speed_limit_mps) or self._calls.step
        """Each SUMO step of the egos' periods before the observers see it: SUMO's own or the traffic's."""
        self._compose_step()
        # a SUMO process is closed at the latest when this simulation is collected or the process ends: dropped with
        # its socket, it would report "peer shutdown" and "Quitting (on error)" where no error happened
        self._closing = weakref.finalize(self, _close_quietly, api) if self.transport == "traci" else None

    def _compose_step(self) -> None:
        """The step of the egos' periods (`_calls.step`): the traffic's or SUMO's, then the every-step observers."""
        step, observers = self._sumo_step, tuple(self._observers)
        if not observers:
            self._calls = self._calls._replace(step=step)
            return
        read = self.vehicle_rows

        def observed_step() -> None:
            step()
            moment = Moment(self.time_s, "step", read)
            for observer in observers:
                observer(moment)

        self._calls = self._calls._replace(step=observed_step)

    def watch(self, observer: Observer) -> None:
        """Call `observer` (every_step) after each SUMO step of the egos' periods, of a seat and of `advance`, until
        `unwatch`. An observer of decisions (not every_step) is refused: the env (`ParallelHighwayEnv.watching`)
        shows it each reset and decision."""
        if not observer.every_step:
            raise ValueError(f"{type(observer).__name__} watches decisions, not SUMO steps: give it to the env's "
                             "watching, which shows it each reset and decision")
        self._observers.append(observer)
        self._compose_step()

    def unwatch(self, observer: Observer) -> None:
        """Stop calling `observer`."""
        self._observers.remove(observer)
        self._compose_step()

    @contextlib.contextmanager
    def watching(self, observer: WatchedObserver) -> Iterator[WatchedObserver]:
        """`watch` `observer` within the block."""
        self.watch(observer)
        try:
            yield observer
        finally:
            self.unwatch(observer)

    def vehicle_rows(self) -> Rows:
        """Every vehicle on the road now as rows (`sumo_rail.sim.observers.ROW_FIELDS`)."""
        if self._rows is None:
            self._rows = VehicleRows(self._api, self._constants)
        return self._rows.read()

    def advance(self, steps: int) -> None:
        """Run `steps` SUMO steps, no ego watched (the observers see each)."""
        step = self._calls.step
        for _ in range(steps):
            step()

    def load_empty(self, begin_s: float, sumo_seed: int) -> None:
        """Load the road afresh, no warm state, its clock (`time_s`) at `begin_s` [s], with SUMO seed `sumo_seed` (a
        traffic that places its vehicles itself: `sumo_rail.sim.replay`). SUMO's own clock begins on its step grid, at
        or before `begin_s` (off the grid SUMO warns), `clock_offset_s` making up the rest."""
        self._require_running()
        step_ms = round(self.scenario.step_length_s * 1000)
        begin_ms = round(begin_s * 1000)  # SUMO's clock counts whole milliseconds
        sumo_begin_s = begin_s if begin_ms % step_ms == 0 else begin_ms // step_ms * step_ms / 1000
        options = ["--begin", repr(sumo_begin_s), "--seed", str(sumo_seed)]
        self._load(options)
        if abs(self._api.simulation.getTime() - sumo_begin_s) > self.scenario.step_length_s / 2:
            self._load(options)  # over TraCI, SUMO (1.28) keeps the last load's clock when a load begins earlier
        self.clock_offset_s = begin_s - sumo_begin_s
        self._zip_merging.clear()

    def _load(self, extra: list[str]) -> None:
        self.forget_sizes()  # a loaded state may give known ids to other vehicles
        self._rows = None
        self.clock_offset_s = 0.0
        try:
            self._api.load([*self._options(), *self._gui_options(), *extra])
        except self._client.TraCIException as error:
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
                with written_atomically(path) as temporary:
                    api.simulation.saveState(str(temporary))
        log.info("saved %d warm states in %s", len(paths), paths[0].parent)

    def reset(self, warm_state: int, sumo_seed: int, ego_lane: int, ego_position_m: float,
              pool: str = "train") -> list[str]:
        """Reload warm state `warm_state` of `pool` with SUMO seed `sumo_seed` and insert the ego; steps until it
        is in. Returns [] (`reset_egos`: the ego is in, or EgoCouldNotEnter)."""
        return self.reset_egos(warm_state, sumo_seed, [(EGO_ID, ego_lane, ego_position_m)], pool)

    def reset_egos(self, warm_state: int, sumo_seed: int, egos: Sequence[tuple[str, int, float]],
                   pool: str = "train") -> list[str]:
        """`reset` with several egos: queue each (vehicle id, lane, front position [m]) in this order, then step
        until all are in (an ego drives on as soon as it is in). SUMO tries no other vehicle in a lane once one
        fails there in a step, so egos still waiting take turns at being tried first; and while traffic queues to
        enter the road (a flow above what its start lets in) SUMO never gets to the egos behind that queue, so they
        are placed at once where that is safe (`EgoPlacement._place_past_queue`). An ego not on the road after
        `ENTRY_WAIT_S` (no room at its place all along, or gone already) sits the episode out: returns those ids,
        in order (EgoCouldNotEnter when none of the egos is on the road)."""
        self._require_running()
        self.traffic.check_warm_start()
        try:
            self._load(["--load-state", str(self._pool(pool)[warm_state]), "--seed", str(sumo_seed)])
        except SimulationError as error:  # a cached file damaged since the start: rebuild what is damaged, once
            log.warning("%s; checking the cached network and warm states", error)
            self.traffic.network(self.scenario)
            self._warm_states.forget()
            self._load(["--load-state", str(self._pool(pool)[warm_state]), "--seed", str(sumo_seed)])
        self._zip_merging.clear()
        for ego in egos:
            self._insert(*ego)
        pending = list(egos)
        for _ in range(round(ENTRY_WAIT_S / self.scenario.step_length_s)):
            self._api.simulationStep()
            departed = set(self._api.simulation.getDepartedIDList())
            pending = [ego for ego in pending if ego[0] not in departed]
            if pending:
                pending = self._place_past_queue(pending)
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
            raise EgoCouldNotEnter(f"{who} could not enter lane {lane} at {position_m:.1f} m within "
                                   f"{ENTRY_WAIT_S:g} s: traffic is too dense there (scenario.flow_veh_per_h is "
                                   f"{self.scenario.flow_veh_per_h:g} veh/h; a lower flow leaves room)")
        for vehicle, lane, position_m in pending:  # said only when the others drive on (the error says it otherwise)
            log.warning("ego %s could not enter lane %d at %.1f m within %g s", vehicle, lane, position_m,
                        ENTRY_WAIT_S)
        if self.gui:
            self._follow_ego(next(ego[0] for ego in egos if ego not in absent))
        return [vehicle for vehicle, _, _ in absent]

    def _follow_ego(self, vehicle: str = EGO_ID) -> None:
        """Point sumo-gui's view at an ego: tracked, zoomed to its surroundings, drawn in red."""
        sumo_gui.follow(self._api, vehicle)

    def screenshot(self, path: Path, width_px: int = 1280, height_px: int = 800) -> None:
        """Save sumo-gui's view to `path` (PNG) when the next step is drawn (sumo-gui only)."""
        if not self.gui:
            raise SimulationError("screenshots need sumo-gui (render_mode='human')")
        self._api.gui.screenshot(sumo_gui.VIEW, str(path), width_px, height_px)

    @property
    def speed_limit_mps(self) -> float:
        """The road's speed limit [m/s]: scenario.speed_limit_mps, or the highest along a user's route."""
        return self._built.speed_limit_mps or self.scenario.speed_limit_mps

    def close(self) -> None:
        """End SUMO; calling it again is harmless."""
        global _ACTIVE_LIBSUMO
        if not self._running:
            return
        self._running = False
        if _ACTIVE_LIBSUMO is self:
            _ACTIVE_LIBSUMO = None
        if self._closing is not None:
            self._closing()
        else:
            _close_quietly(self._api)

    def _require_running(self) -> None:
        if not self._running:
            raise SimulationError("this simulation is closed; create a new one")


def _close_quietly(api: object) -> None:
    """Close a SUMO connection, logging (not raising) an error of a SUMO already gone."""
    try:
        api.close()  # type: ignore[attr-defined]
    except Exception as error:
        log.debug("ignored error while closing SUMO: %s", error)


def sumo_options(scenario: ScenarioConfig, built: network.BuiltNetwork) -> list[str]:
    """Every SUMO option that shapes a simulation of `scenario` on `built`, explicitly (the network and route files
    first, then `run_options`)."""
    return ["--net-file", str(built.net_file), "--route-files", built.route_files, *run_options(scenario)]


def run_options(scenario: ScenarioConfig) -> list[str]:
    """The SUMO options of a simulation of `scenario` besides its files: its step, lane changes, collisions, and
    SUMO's own randomness and logs."""
    s = scenario
    return [
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
