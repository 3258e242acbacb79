"""The ego in a recorded driver's seat: `SceneEnv` is `HighwayEnv` on a scene's road whose traffic is the scene's
vehicles (`scene_traffic`), and whose every reset puts the ego where one recorded vehicle is at a chosen instant, at
its recorded lane, position, speed, length and width, that vehicle then left out of the replay. The ego then drives
exactly as in the generated roads (the same actions, ACC, observation, rewards, safety readings), until the
episode's horizon (`env.max_episode_s`), a collision or the end of the road. The human's recorded track is the
reference of the episode (`sumo_rail.evaluation.scene_evaluation`).

Scenes on one straight edge only (highD, NGSIM, record-sumo-drivers; an FCD recording on a user's network of several
edges is refused in one sentence, as for `recorded-demos`). The seat's driver may also be SUMO itself: with reset
option `"sumo_driver": True` the ego is given SUMO's IDM car following and LC2013 lane changing (a type of the
scene's routes file, `IDM_TYPE`), desired speed the ego's top set-point, and the actions passed to `step` are ignored.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, write_bytes_atomically
from sumo_rail.recordings.scene import Scene, read_scene
from sumo_rail.recordings.scene_observations import SceneFrames, SceneRoad, scene_road
from sumo_rail.recordings.scene_traffic import LANE_CHANGE_MODE_SUMO, REPLAY_ROUTE, SceneTraffic
from sumo_rail.recordings.trajectory import track_past
from sumo_rail.sim.ego import CONTEXT_MARGIN_M, Ego
from sumo_rail.sim.ego_past import EgoPast
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.simulation import EGO_ID, Simulation, SimulationError, sumo_options
from sumo_rail.sim.vehicles import PeriodReport

IDM_TYPE = "scene_idm"
"""The vehicle type of a SUMO-driven seat: IDM car following, LC2013 lane changing, SUMO's default parameters."""


def scene_config(config: Config, scene: Scene, road: SceneRoad) -> Config:
    """`config` on the scene's road: kind network, the scene's network and its one edge, the scene's lanes."""
    return config.with_overrides({"scenario": {"kind": "network", "network": str(scene.network.resolve()),
                                               "route": road.edge, "traffic_file": "", "lanes": road.lanes}})


class SceneSimulation(Simulation):
    """A `Simulation` of a scene's road whose traffic is the scene's vehicles, stepped with them (`SceneTraffic`)."""

    def __init__(self, config: Config, frames: SceneFrames, tracks: pd.DataFrame, road: SceneRoad, reactive: bool,
                 transport: str = "libsumo", gui: bool = False) -> None:
        self.frames, self.road = frames, road
        self._routes: Path | None = None
        self.ego_collisions: list[tuple[str, str]] = []
        """(collider, victim) of each collision of the ego in the episode (SUMO's collider: the follower)."""
        self._step_s = config.scenario.step_length_s
        self._ego_in = False
        """The ego is on the road (seated, not yet gone)."""
        self._seat_size_m = (0.0, 0.0)
        """The seat's recorded length and width [m]."""
        self.seated: tuple[str, float] = ("", 0.0)
        """The recorded vehicle whose seat the ego took and when [s]."""
        super().__init__(config.scenario, config.lidar.range_m + CONTEXT_MARGIN_M, gui=gui, transport=transport)
        self.traffic = SceneTraffic(frames, tracks, road.edge, reactive, self.speed_limit_mps)
        self.traffic.api = self._api

    def _options(self) -> list[str]:
        """The routes file without the generated flow, with the replay's route and the IDM seat's type."""
        if self._routes is None:
            root = ElementTree.parse(self._built.routes_file).getroot()
            for flow in root.findall("flow"):
                root.remove(flow)
            ElementTree.SubElement(root, "route", id=REPLAY_ROUTE, edges=self.road.edge)
            ElementTree.SubElement(root, "vType", id=IDM_TYPE, carFollowModel="IDM", laneChangeModel="LC2013")
            self._routes = self._built.directory / "scene.rou.xml"
            write_bytes_atomically(self._routes, ElementTree.tostring(root))
        return sumo_options(self.scenario, dataclasses.replace(self._built, routes_file=self._routes))

    def _start(self, extra: list[str]) -> None:
        super()._start(extra)
        self._calls = self._calls._replace(step=self._replaying_step)

    def _replaying_step(self) -> None:
        """One SUMO step with the recorded vehicles placed for its end; the ego's collisions kept."""
        end_s = self._api.simulation.getTime() + self._step_s
        self.traffic.place(end_s, self._api.vehicle.getPosition(EGO_ID)[0] if self._ego_in else None)
        self._api.simulationStep(end_s)  # to a time: over traci a plain step after a load may keep SUMO's clock
        simulation = self._api.simulation
        if simulation.getCollidingVehiclesNumber():
            self.ego_collisions += [(collision.collider, collision.victim) for collision in simulation.getCollisions()
                                    if EGO_ID in (collision.collider, collision.victim)]
            self._ego_in = self._ego_in and not self.ego_collisions
        if self._ego_in and simulation.getArrivedNumber() and EGO_ID in simulation.getArrivedIDList():
            self._ego_in = False

    def advance_egos(self, steps: int, vehicles: Sequence[str], watch: Sequence[str] = ()) -> list[PeriodReport]:
        """`Stepping.advance_egos`, and a collision of the ego with a replayed vehicle in the period's last step said
        as one: SUMO then still answers for the ego (it leaves at the next step) but no longer sees it."""
        reports = super().advance_egos(steps, vehicles, watch)
        return [dataclasses.replace(report, ego_collided=True, ego_left_network=False)
                if vehicle == EGO_ID and self.ego_collisions and not report.ego_collided else report
                for vehicle, report in zip(vehicles, reports, strict=True)]

    def _why_gone(self, vehicle: str) -> tuple[bool, bool]:
        """A collision with a replayed vehicle (moved by moveToXY) may leave the ego answering for the rest of the
        step and unknown only at the next, whose collision list no longer names it: the episode's own record says."""
        if vehicle == EGO_ID and self.ego_collisions:
            return True, False
        return super()._why_gone(vehicle)

    def reset_egos(self, warm_state: int, sumo_seed: int, egos: Any, pool: str = "train") -> list[str]:
        raise SimulationError("a scene's episodes start in a recorded vehicle's seat (seat), not from warm states")

    def seat(self, vehicle: str, start_s: float, sumo_seed: int) -> None:
        """Load the scene's road afresh at `start_s` [s] with SUMO seed `sumo_seed`, place the recorded vehicles
        there (but `vehicle`) and put the ego in `vehicle`'s place, state and size."""
        self._require_running()
        self._load(["--begin", repr(start_s - self._step_s), "--seed", str(sumo_seed)])
        self._zip_merging.clear()
        self.ego_collisions.clear()
        self._ego_in = False
        self.seated = (vehicle, start_s)
        self.traffic.begin(vehicle)
        self._calls.step()
        ids, values, lanes = self.frames.at(start_s)
        row = np.flatnonzero(ids == vehicle)
        if not len(row):
            raise DatasetError(f"vehicle {vehicle} of the scene is not on the road at {start_s:g} s")
        k, vehicle_api = int(row[0]), self._api.vehicle
        speed_mps = float(values["speed_mps"][k])
        # placed standing, then given the recorded speed: SUMO refuses a departure above the type's limit on the lane
        self._force_in(EGO_ID, int(lanes[k]), float(values["lane_position_m"][k]), 0.0)
        vehicle_api.setSpeedFactor(EGO_ID, max(1.0, speed_mps / self.speed_limit_mps))
        vehicle_api.setPreviousSpeed(EGO_ID, speed_mps)
        self._seat_size_m = (float(values["length_m"][k]), float(values["width_m"][k]))
        self._size_ego()
        self._ego_in = True

    def _size_ego(self) -> None:
        """Give the ego its seat's recorded length and width [m]."""
        self._api.vehicle.setLength(EGO_ID, self._seat_size_m[0])
        self._api.vehicle.setWidth(EGO_ID, self._seat_size_m[1])
        self.forget_sizes(EGO_ID)

    def hand_to_sumo(self, desired_mps: float) -> None:
        """Give the seated ego to SUMO: IDM car following, LC2013 lane changing, desired speed `desired_mps`."""
        vehicle = self._api.vehicle
        vehicle.setType(EGO_ID, IDM_TYPE)
        self._size_ego()  # a new type brings its own size
        vehicle.setLaneChangeMode(EGO_ID, LANE_CHANGE_MODE_SUMO)
        vehicle.setSpeedFactor(EGO_ID, desired_mps / self.speed_limit_mps)


@dataclass(frozen=True)
class SeatStart:
    """The `StartRule` of a recorded scene (`scene`, its `frames` and `road`): every reset seats the ego in a
    recorded vehicle (reset options "vehicle", "start_s", "sumo_driver"; see `SceneEnv`)."""

    scene: Scene
    frames: SceneFrames
    road: SceneRoad
    reactive: bool
    options: tuple[str, ...] = ("vehicle", "start_s", "sumo_driver")

    def simulation(self, config: Config, transport: str, gui: bool, gui_delay_ms: float) -> Simulation:
        return SceneSimulation(config, self.frames, self.scene.tracks, self.road, self.reactive, transport, gui=gui)

    def enter(self, sim: Simulation, rng: np.random.Generator, config: Config, agents: Sequence[str],
              options: dict[str, Any]) -> list[str]:
        if "vehicle" not in options:
            raise ValueError("SceneEnv.reset needs options={'vehicle': ID}: the recorded vehicle whose seat the ego "
                             "takes")
        assert isinstance(sim, SceneSimulation) and tuple(agents) == (EGO_ID,)
        vehicle, step_s = str(options["vehicle"]), config.scenario.step_length_s
        # SUMO's run begins one step before the seat: a track from the scene's first instant is taken one step in
        start_s = float(options.get("start_s", max(self.scene.track(vehicle)["time_s"].iloc[0], step_s)))
        if start_s < step_s:
            raise ValueError(f"reset option 'start_s' must be at least one SUMO step ({step_s:g} s) into the scene, "
                             f"got {start_s:g}")
        sim.seat(vehicle, start_s, int(rng.integers(2**31 - 1)))
        return []

    def past(self, sim: Simulation, agent: str) -> EgoPast:
        """The seated vehicle's recorded lead-in: its track before the seat's instant."""
        assert isinstance(sim, SceneSimulation)
        vehicle, start_s = sim.seated
        track = self.scene.track(vehicle)
        return track_past(track[track["time_s"] < start_s - 1e-9])

    def started(self, sim: Simulation, egos: Mapping[str, Ego], options: dict[str, Any]) -> None:
        """With "sumo_driver", SUMO's IDM and LC2013 take the seat, desired speed the ego's top set-point."""
        if options.get("sumo_driver", False):
            assert isinstance(sim, SceneSimulation)
            ego = egos[EGO_ID]
            sim.hand_to_sumo(ego.top_speed_mps(sim))
            ego.sumo_driven = True


class SceneEnv(HighwayEnv):
    """`HighwayEnv` in a recorded scene (`scene`: a scene folder) with its vehicles replayed (`reactive` False) or
    driven by SUMO from their recorded state (True). `reset(options={"vehicle": ID, "start_s": T})` seats the ego
    in vehicle ID at T [s] (default: where its track begins, or one SUMO step into the scene for a vehicle there
    from its first instant); `"sumo_driver": True` lets SUMO drive it (the actions
    passed to `step` are then checked, not used)."""

    def __init__(self, config: Config | Mapping[str, Any] | str | Path | None, scene: Path | Scene,
                 reactive: bool = False, render_mode: str | None = None, transport: str = "auto") -> None:
        self.scene = scene if isinstance(scene, Scene) else read_scene(Path(scene))
        self.frames = SceneFrames(self.scene.tracks, self.scene.meta.frame_rate_hz)
        self.road = scene_road(self.scene.network)
        self.reactive = reactive
        super().__init__(scene_config(Config.coerce(config), self.scene, self.road), render_mode=render_mode,
                         transport=transport, start=SeatStart(self.scene, self.frames, self.road, reactive))

    @property
    def ego_collisions(self) -> list[tuple[str, str]]:
        """(collider, victim) of the ego's collisions in this episode."""
        sim = self.simulation
        return sim.ego_collisions if isinstance(sim, SceneSimulation) else []
