"""The ego in a recorded driver's seat: `SceneEnv` is `HighwayEnv` on a scene's road whose traffic is the scene's
vehicles (`sumo_rail.sim.replay.ReplayedTraffic`, given the scene's frames), and whose every reset puts the ego where
one recorded vehicle is at a chosen instant, at its recorded lane, position, speed, length, width and vehicle class
(a truck's seat is a truck's), that vehicle
then left out of the replay. The ego then drives exactly as in the generated roads (the same actions, ACC,
observation, rewards, safety readings), until the episode's horizon (`env.max_episode_s`), a collision or the end of
the road. The human's recorded track is the reference of the episode (`sumo_rail.evaluation.scene_evaluation`).

Scenes on any SUMO network (several edges, bends, ramps, lane drops): the env's route is the network's main road
(`NetFile.main_route`); the seated ego drives the recorded vehicle's own edges from where it is, in that route's frame
(its observation's positions, lanes and route block), as `recorded-demos` reads it. The seat's driver may also be
SUMO itself: with the env core's reset option `"controller": "sumo"` the ego is given SUMO's IDM car following and
LC2013 lane changing (`sumo_rail.sim.controllers.SumoController`), desired speed the ego's top set-point, and the
actions passed to `step` are checked, not used.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sumo_rail.config import Config, EnvConfig
from sumo_rail.recordings.scene import SPEED_TOLERANCE_MPS, Scene, read_scene
from sumo_rail.recordings.scene_drivers import reactive_types
from sumo_rail.recordings.scene_observations import SceneFrames, SceneRoad, scene_road, scene_routes
from sumo_rail.recordings.seats import SeatDraw
from sumo_rail.recordings.trajectory import PAST_COLUMNS, track_past
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.ego_past import EgoPast
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.replay import NO_TYPES, ReplayedTraffic, VehicleTypes
from sumo_rail.sim.simulation import EGO_ID, Simulation


def scene_config(config: Config, scene: Scene, road: SceneRoad) -> Config:
    """`config` on the scene's road: kind network, the scene's network and its main road's route, the scene's
    lanes."""
    return config.with_overrides({"scenario": {"kind": "network", "network": str(scene.network.resolve()),
                                               "route": " ".join(road.route), "traffic_file": "",
                                               "lanes": road.lanes}})


SEAT_HORIZON_S = 15.0
"""A seat's episode length [s] when nothing chooses one (`evaluate-scene --horizon-s`'s default): the generated road's
env.max_episode_s, 300 s, is longer than the tracks of most recordings, which would leave no seat to draw."""


def horizon_config(config: Config, horizon_s: float | None) -> Config:
    """`config` whose episodes last `horizon_s` [s]; None: its env.max_episode_s, or `SEAT_HORIZON_S` where that is
    the default (as `evaluate-scene` takes a default env.max_episode_s for unset)."""
    if horizon_s is None:
        if config.env.max_episode_s != EnvConfig().max_episode_s:
            return config
        horizon_s = SEAT_HORIZON_S
    return config.with_overrides({"env": {"max_episode_s": horizon_s}})


def road_limit_config(config: Config, road: SceneRoad) -> Config:
    """`config` driving at the road's speed limit as `check_speed_limit` asks: scenario.speed_limit_mps that limit
    and env.v_max_mps not below it (a config that already does is returned as it is)."""
    limit = road.speed_limit_mps
    overrides: dict[str, dict[str, float]] = {}
    if abs(config.scenario.speed_limit_mps - limit) > SPEED_TOLERANCE_MPS:
        overrides["scenario"] = {"speed_limit_mps": limit}
    if config.env.v_max_mps < limit - SPEED_TOLERANCE_MPS:
        overrides["env"] = {"v_max_mps": limit}
    return config.with_overrides(overrides) if overrides else config


@dataclass(frozen=True)
class SeatStart:
    """The `StartRule` of a recorded scene (`scene`, its `frames` and `road`): the simulation's traffic is the
    scene's vehicles (`ReplayedTraffic`, `reactive` or not, SUMO's vehicle types `types`), every reset seats the ego
    in a recorded vehicle (reset options "vehicle" and "start_s", else a seat `seats` draws; see `SceneEnv`)."""

    scene: Scene
    frames: SceneFrames
    road: SceneRoad
    reactive: bool
    seats: SeatDraw
    types: VehicleTypes = NO_TYPES
    options: tuple[str, ...] = ("vehicle", "start_s")

    def simulation(self, config: Config, transport: str, gui: bool, gui_delay_ms: float) -> Simulation:
        tracks = self.scene.tracks
        top = tracks.groupby("vehicle_id")["speed_mps"].max()
        traffic = ReplayedTraffic(self.frames.at, tracks.groupby("vehicle_id")["time_s"].min().sort_values().to_numpy(),
                                  dict(zip(top.index.astype(str), top.to_numpy(), strict=True)),
                                  scene_routes(tracks), self.reactive,
                                  tracks.groupby("vehicle_id")["vehicle_class"].first().astype(str).to_dict(),
                                  self.types)
        return Simulation(config.scenario, config.lidar.range_m + CONTEXT_MARGIN_M, gui=gui, transport=transport,
                          gui_delay_ms=gui_delay_ms, traffic=traffic)

    def enter(self, sim: Simulation, rng: np.random.Generator, config: Config, agents: Sequence[str],
              options: dict[str, Any]) -> list[str]:
        if "vehicle" not in options:
            seat = self.seats.draw(rng)
            options = {**options, "vehicle": seat.vehicle, "start_s": seat.start_s}
        assert tuple(agents) == (EGO_ID,)
        vehicle, step_s = str(options["vehicle"]), config.scenario.step_length_s
        # SUMO's run begins one step before the seat: a track from the scene's first instant is taken one step in
        start_s = float(options["start_s"] if "start_s" in options
                        else max(self.scene.track(vehicle)["time_s"].iloc[0], step_s))
        if not step_s <= start_s < math.inf:  # NaN too: SUMO would be asked to begin at it
            raise ValueError(f"reset option 'start_s' must be a time at least one SUMO step ({step_s:g} s) into the "
                             f"scene, got {start_s:g}")
        replayed(sim).seat(sim, vehicle, start_s, int(rng.integers(2**31 - 1)))
        return []

    def past(self, sim: Simulation, agent: str) -> EgoPast:
        """The seated vehicle's recorded lead-in: its track before the seat's instant."""
        vehicle, start_s = replayed(sim).seated
        track = self.scene.track_values(vehicle, PAST_COLUMNS)
        before = track["time_s"] < start_s - 1e-9
        return track_past({name: values[before] for name, values in track.items()})


def replayed(sim: Simulation) -> ReplayedTraffic:
    """The scene's traffic of a simulation `SeatStart` made."""
    assert isinstance(sim.traffic, ReplayedTraffic)
    return sim.traffic


class SceneEnv(HighwayEnv):
    """`HighwayEnv` in a recorded scene (`scene`: a scene folder) with its vehicles replayed (`reactive` False) or
    driven by SUMO from their recorded state (True). `reset(options={"vehicle": ID, "start_s": T})` seats the ego
    in vehicle ID at T [s] (default: where its track begins, or one SUMO step into the scene for a vehicle there
    from its first instant); `"controller": "sumo"` lets SUMO drive it (the actions passed to `step` are then
    checked, not used). `types`: the vehicle types SUMO knows besides its default, with each reactive vehicle's
    (default: `evaluate-scene`'s, `sumo_rail.recordings.scene_drivers.reactive_types`: each vehicle's recorded vType
    where the scene has it, else SUMO's IDM calibrated on the train split; `NO_TYPES`: SUMO's default Krauss).

    A reset without a vehicle (Gymnasium's `reset(seed=...)`, vector envs, Stable-Baselines3) seats the ego in a seat
    of the scene's `split` drawn by the episode's seed (`sumo_rail.recordings.seats.SeatDraw`: a passenger car whose
    track covers `lead_s` [s] of lead-in and `env.max_episode_s`, with `zone_m` [m] where traffic is established, as
    `evaluate-scene --lead-s --zone-m` chooses them); `info` names it ("vehicle", "start_s"). An episode lasts
    `horizon_s` [s] (default: the config's env.max_episode_s, or `SEAT_HORIZON_S` where it is the default's 300 s,
    as `evaluate-scene --horizon-s` does).
    `gymnasium.make("sumo_rail/Scene-v0", scene=FOLDER, config=...)` makes it (`config` as `HighwayEnv` takes it;
    the scene gives the road: its lanes, and its speed limit, `road_limit_config`, as the commands ask of a
    configuration)."""

    def __init__(self, config: Config | Mapping[str, Any] | str | Path | None = None, scene: Path | Scene | None = None,
                 reactive: bool = False, render_mode: str | None = None, transport: str = "auto",
                 types: VehicleTypes | None = None, split: str = "train", lead_s: float = 5.0,
                 zone_m: float = 0.0, gui_delay_ms: float = 100.0, horizon_s: float | None = None) -> None:
        if scene is None:
            raise TypeError("SceneEnv needs a scene: gymnasium.make(SCENE_ENV_ID, scene=FOLDER)")
        self.scene = scene if isinstance(scene, Scene) else read_scene(Path(scene))
        self.frames = SceneFrames(self.scene.tracks, self.scene.meta.frame_rate_hz)
        self.road = scene_road(self.scene.network)
        self.reactive = reactive
        config = horizon_config(road_limit_config(scene_config(Config.coerce(config), self.scene, self.road),
                                                  self.road), horizon_s)
        if types is None:
            types = reactive_types(self.scene, config.scenario.step_length_s).types if reactive else NO_TYPES
        seats = SeatDraw(self.scene, split, config.env.max_episode_s, lead_s, zone_m, config.scenario.step_length_s)
        super().__init__(config, render_mode=render_mode, transport=transport, gui_delay_ms=gui_delay_ms,
                         start=SeatStart(self.scene, self.frames, self.road, reactive, seats, types))

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[np.ndarray, dict[str, Any]]:
        observation, info = super().reset(seed=seed, options=options)
        vehicle, start_s = replayed(self.simulation).seated if self.simulation is not None else (None, None)
        return observation, {**info, "vehicle": vehicle, "start_s": start_s}

    @property
    def ego_collisions(self) -> list[tuple[str, str]]:
        """(collider, victim) of the ego's collisions in this episode."""
        sim = self.simulation
        return [] if sim is None else replayed(sim).ego_collisions
