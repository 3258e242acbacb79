"""Drivers in recorded drivers' seats (closed loop): each driver takes each chosen held-out vehicle's place in its
scene (`sumo_rail.recordings.seat.SceneEnv`) for a fixed horizon, non-reactive or reactive, and is measured against
that vehicle's recorded track.

A seat is a held-out vehicle of the chosen classes (passenger cars by default, trucks too: the ego takes the seat's
vehicle class, length and width) whose track covers `lead_s` + `horizon_s` [s]; the ego starts
`lead_s` after the track begins (the car is fully on the road and has moved with its traffic). Per episode: the
paper's metrics, the safety measures (`safety.SafetyObserver`), the position error against the human's track at 1, 2,
5, 10, 15 and 20 s and the RMSE of position and speed over the seat (`human_likeness`), collisions and those the ego
caused (SUMO names the ego the collider: it ran into the other; a replayed vehicle running into the ego from behind
is the other's fault), a stop (speed below `STOP_MPS`), the progress relative to the human (distances along the road
over the same time), lane changes per km and the driving score with its parts (`driving_score`; the human's distance
is the reference's). Per decision, for the distributions: the ego's and, once per seat, the human's time, position,
speed, lane and gap to the leader in its lane. The episodes are `protocol.EvaluationTask`s from a
`RecordedSeatStart`, watched by `Safety` and `SeatTrack`. SUMO's IDM may take the seat with its own parameters
("sumo-idm") or those calibrated on the scene's train split (`CalibratedIdmDriver`, "sumo-idm-calibrated"; its desired
speed, read from the seated driver's lead-in, is the episode's `desired_mps`); the reactive vehicles are driven as
`scene_drivers.reactive_types` says (`evaluate_seats`' `reactive_types`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS, driving_scores
from sumo_rail.evaluation.human_likeness import HORIZONS_S, position_errors, track_rmse
from sumo_rail.evaluation.protocol import NAMED_DRIVERS, Evaluation, EvaluationTask, Tables, plain_table
from sumo_rail.evaluation.safety import Safety
from sumo_rail.evaluation.scene_summary import HUMAN, seats_summary
from sumo_rail.recordings.idm import IdmParameters
from sumo_rail.recordings.idm_calibration import IdmCalibration, lead_in_desired_speed
from sumo_rail.recordings.scene import Scene, read_scene
from sumo_rail.recordings.scene_drivers import SEAT_IDM_TYPE, idm_type, seat_calibration
from sumo_rail.recordings.scene_observations import (
    SceneFrames,
    SceneRoad,
    in_frame,
    route_from,
    scene_road,
    scene_routes,
)
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.seats import Seat
from sumo_rail.recordings.trajectory import TRAJECTORY_COLUMNS, TrajectoryPoint, trajectory_frame
from sumo_rail.runners.backends import RolloutBackend, WorkerContext
from sumo_rail.runners.rollout import Driver, DriverSpec, KeepDriver, SumoIdmDriver
from sumo_rail.runners.video import video_name
from sumo_rail.sim.controllers import SumoController
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observers import Moment
from sumo_rail.sim.replay import NO_TYPES, VehicleTypes
from sumo_rail.sim.traffic import TrafficView, ego_leader_gap_m

STOP_MPS = 0.5
"""A speed below this is a stop [m/s]."""
SEAT_DRIVERS: dict[str, DriverSpec] = {**NAMED_DRIVERS, "sumo-idm": SumoIdmDriver()}
"""The drivers a --policy word names in a recorded seat: any road's and SUMO's IDM (the seat's "sumo" controller)."""
MODES = {"non-reactive": False, "reactive": True}
SCENE_EPISODES, SCENE_TRACKS = "scene_episodes", "scene_tracks"
"""The `kind` in the provenance of evaluate-scene's two tables."""


def measured_gap(gap_m: float, range_m: float) -> float:
    """A gap to the leader [m] as a headway sample: NaN beyond `range_m` [m] (the LIDAR's, `lidar.range_m`) or
    without a leader (inf)."""
    return gap_m if gap_m <= range_m else np.nan


@dataclass(frozen=True)
class RecordedSeatStart:
    """An episode in `seat` of its scene, non-reactive or `reactive` (`sumo_rail.recordings.seat.SceneEnv`), SUMO
    knowing the vehicle types `types` (the reactive vehicles' and a SUMO-driven seat's); `controller`: the seat's own
    controller, where the seat fixes it (the calibrated IDM's desired speed is the seated driver's)."""

    config: Config
    seat: Seat
    reactive: bool
    types: VehicleTypes = NO_TYPES
    controller: SumoController | None = None

    def env(self, context: WorkerContext) -> HighwayEnv:
        types = self.types
        env = context.custom_env(("scene", self.config, self.seat.scene, self.reactive, types.key),
                                 lambda: SceneEnv(self.config, Path(self.seat.scene), self.reactive,
                                                  context.render_mode, "libsumo", types,
                                                  gui_delay_ms=context.gui_delay_ms,
                                                  horizon_s=self.config.env.max_episode_s))
        assert isinstance(env, SceneEnv)
        return env

    def options(self) -> dict[str, Any]:
        return {"vehicle": self.seat.vehicle, "start_s": self.seat.start_s,
                **({} if self.controller is None else {"controller": self.controller})}


CALIBRATED_IDM = "sumo-idm-calibrated"
"""The driver name of SUMO's IDM calibrated on each scene's train split."""


@dataclass(frozen=True)
class CalibratedIdmDriver:
    """SUMO's IDM and LC2013 in the seat with each scene's calibrated parameters for the seat's class (`idm`:
    `calibration_key`, parameters, the train drivers' median desired speed [m/s]) and the desired speed read from the
    seated driver's lead-in; asks for
    SUMO's controller, which each seat's start gives (`seat_controller`); the actions (keep's) are not used."""

    idm: tuple[tuple[str, IdmParameters, float], ...]
    name: str = CALIBRATED_IDM
    controller: str = SumoController.name

    def create(self, config: Config, seed: int) -> Driver:
        return KeepDriver().create(config, seed)

    def seat_controller(self, scene: Scene, seat: Seat, step_s: float) -> tuple[SumoController, VehicleTypes]:
        """The controller of `seat` in `scene` (SUMO's step `step_s` [s]) and the vehicle type it needs defined."""
        key = calibration_key(seat.scene, str(scene.track(seat.vehicle)["vehicle_class"].iloc[0]))
        parameters, typical = {name: (found, median) for name, found, median in self.idm}[key]
        desired = lead_in_desired_speed(scene.tracks, scene.road, seat.vehicle, seat.start_s, parameters, step_s,
                                        typical_mps=typical)
        return SumoController(self.name, SEAT_IDM_TYPE, desired), VehicleTypes({SEAT_IDM_TYPE: idm_type(parameters)})


def calibration_key(folder: str, vehicle_class: str) -> str:
    """The name of a scene's calibration for seats of `vehicle_class`: its folder (passenger cars), else the folder and
    the class."""
    return folder if vehicle_class == "passenger" else f"{folder} ({vehicle_class})"


def calibrated_idm_driver(scenes: Sequence[Scene], step_s: float, lead_s: float, horizon_s: float,
                          seats: Sequence[Seat] = ()) -> tuple[CalibratedIdmDriver, dict[str, IdmCalibration]]:
    """SUMO's IDM calibrated on each scene's train seats (`scene_drivers.seat_calibration`), one for each vehicle class
    of its `seats` (passenger cars when none is given), and the calibrations by `calibration_key`; ValueError naming
    the scene where no IDM can be fitted."""
    calibrations: dict[str, IdmCalibration] = {}
    for scene in scenes:
        folder, kinds = str(scene.folder), scene.tracks.groupby("vehicle_id")["vehicle_class"].first()
        classes = sorted({str(kinds[seat.vehicle]) for seat in seats if seat.scene == folder}) or ["passenger"]
        calibrations |= {calibration_key(folder, kind): seat_calibration(scene, step_s, lead_s, horizon_s, kind)
                         for kind in classes}
    return CalibratedIdmDriver(tuple((key, found.parameters, found.desired_mps)
                                     for key, found in calibrations.items())), calibrations


def seat_start(config: Config, seat: Seat, reactive: bool, driver: DriverSpec, scene: Scene,
               reactive_types: VehicleTypes) -> RecordedSeatStart:
    """The start of `driver`'s episode in `seat` of `scene`: the reactive vehicles of `reactive_types` (when
    `reactive`), and a calibrated IDM's seat controller and type."""
    types, controller = reactive_types if reactive else NO_TYPES, None
    if isinstance(driver, CalibratedIdmDriver):
        controller, seat_types = driver.seat_controller(scene, seat, config.scenario.step_length_s)
        types = VehicleTypes({**types.definitions, **seat_types.definitions}, types.of_vehicle)
    return RecordedSeatStart(config, seat, reactive, types, controller)


@dataclass(frozen=True)
class SeatTrack:
    """Observes the ego's track in a seat (`TrackObserver`): an evaluation's `protocol.ObserverSpec`."""

    start_s: float

    def create(self, config: Config, seed: int) -> TrackObserver:
        return TrackObserver(self.start_s, config.env.decision_period_s, config.lidar.range_m)


class TrackObserver:
    """The ego's state at every decision (`TrajectoryPoint`s, the first at `start_s`, one every `period_s` [s], the gap
    to its leader measured within `range_m` [m]) and the state it ended in unless it collided; with the collisions it
    caused and the speed limit (an observer of each reset and decision, `sumo_rail.sim.observers`)."""

    every_step = False

    def __init__(self, start_s: float, period_s: float, range_m: float) -> None:
        self.start_s, self.period_s, self.range_m = start_s, period_s, range_m
        self.points: list[TrajectoryPoint] = []

    def __call__(self, moment: Moment) -> None:
        for decision in moment.decisions():
            self.add(decision.traffic)

    def add(self, traffic: TrafficView) -> None:
        ego, gap = traffic.ego, ego_leader_gap_m(traffic)
        self.points.append(TrajectoryPoint(self.start_s + len(self.points) * self.period_s, ego.front_x, ego.front_y,
                                           ego.speed_mps, ego.lane, ego.lane_position_m,
                                           measured_gap(gap, self.range_m)))

    def columns(self, env: HighwayEnv, metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """The collisions the ego caused (SUMO named it the collider) and the speed limit [m/s]; the track
        (`TRAJECTORY_COLUMNS`, one entry more than the decisions unless the ego collided)."""
        assert isinstance(env, SceneEnv)
        if metrics["termination"] != "collision":
            self.add(env.traffic)
        track = trajectory_frame(self.points)
        return ({"at_fault_collisions": sum(collider == "ego" for collider, _ in env.ego_collisions),
                 "limit_mps": env.config.scenario.speed_limit_mps},
                {name: track[name].to_numpy() for name in TRAJECTORY_COLUMNS})


def human_track(frames: SceneFrames, seat: Seat, period_s: float, decisions: int, road: SceneRoad,
                recorded: tuple[str, ...], range_m: float) -> pd.DataFrame:
    """The seat's recorded vehicle (which drove the edges `recorded` on the scene's `road`) at the episode's decision
    instants (`TRAJECTORY_COLUMNS`), its lanes and positions in its seat's route frame, as the ego's, its gap to the
    leader measured within `range_m` [m]."""
    points: list[TrajectoryPoint] = []
    route = recorded
    for k in range(decisions + 1):
        time_s = seat.start_s + k * period_s
        snapshot = frames.at(time_s)
        row = snapshot.row(seat.vehicle)
        if row is None:
            break
        route = route if points else route_from(recorded, str(snapshot.values["edge"][row]))
        framed = in_frame(road, route, snapshot)
        points.append(framed.point(row, time_s)._replace(gap_m=measured_gap(framed.leader_gap_m(row), range_m)))
    return trajectory_frame(points)


def seat_columns(driven: pd.DataFrame, human: pd.DataFrame, simulated_s: float) -> dict[str, float]:
    """The measures of one episode against the human's track: position errors, their RMSE and the speed's, progress,
    stop, lane changes."""
    errors = position_errors(driven, human) if len(driven) else np.full(len(HORIZONS_S), np.nan)
    position_rmse, speed_rmse = track_rmse(driven, human) if len(driven) else (np.nan, np.nan)
    start = human["lane_position_m"].iloc[0]
    human_m = float(np.interp(human["time_s"].iloc[0] + simulated_s, human["time_s"], human["lane_position_m"])
                    - start)
    driven_m = float(driven["lane_position_m"].iloc[-1] - driven["lane_position_m"].iloc[0]) if len(driven) else 0.0
    changes = int(np.abs(np.diff(driven["lane"].to_numpy())).sum()) if len(driven) else 0
    return {**{f"position_error_{h:g}s_m": float(e) for h, e in zip(HORIZONS_S, errors, strict=True)},
            "position_rmse_m": position_rmse, "speed_rmse_mps": speed_rmse,
            "human_distance_m": human_m, "progress_ratio": driven_m / human_m if human_m > 0 else np.nan,
            "stopped": bool(len(driven) and driven["speed_mps"].min() < STOP_MPS),
            "lane_changes_per_km": changes / (driven_m / 1000.0) if driven_m > 0 else np.nan}


def evaluate_seats(drivers: Sequence[DriverSpec], names: Sequence[str], config: Config, seats: Sequence[Seat],
                   modes: Sequence[str], backend: RolloutBackend, seed: int,
                   on_episode: Callable[[int, Any], None] | None = None,
                   reactive_types: Mapping[str, VehicleTypes] | None = None, video_episodes: int = 0) -> Evaluation:
    """Every driver in every seat in every mode: one metrics row per episode, one track row per decision with the
    human's rows once per seat and mode under driver `HUMAN`. `reactive_types`: each scene folder's reactive
    vehicles' types (`scene_drivers.reactive_types`; default: SUMO's default Krauss). The first `video_episodes`
    seats of every driver and mode are also recorded as MP4s, named by `seat_video_name`."""
    scenes = {scene: read_scene(Path(scene)) for scene in {seat.scene: None for seat in seats}}
    types = reactive_types or {}
    labelled = [(name, index, EvaluationTask(seat_start(config, seat, MODES[mode], driver, scenes[seat.scene],
                                                        types.get(seat.scene, NO_TYPES)), driver, seed + index,
                                             (Safety(), SeatTrack(seat.start_s)), video=index < video_episodes))
                for mode in modes for driver, name in zip(drivers, names, strict=True)
                for index, seat in enumerate(seats)]
    results = backend.run([task for _, _, task in labelled], on_result=on_episode)
    frames = {scene: (SceneFrames(read.tracks, read.meta.frame_rate_hz), scene_road(read.network),
                      scene_routes(read.tracks)) for scene, read in scenes.items()}
    period = config.env.decision_period_s
    horizon_decisions = round(config.env.max_episode_s / period)
    humans = {seat: human_track(scene_frames, seat, period, horizon_decisions, road, routes[seat.vehicle],
                                config.lidar.range_m)
              for seat in seats for scene_frames, road, routes in [frames[seat.scene]]}
    rows, tracks, videos = [], [], {}
    for (name, index, task), result in zip(labelled, results, strict=True):
        assert isinstance(task.start, RecordedSeatStart)
        seat, driven = task.start.seat, pd.DataFrame({name: result.decisions[name] for name in TRAJECTORY_COLUMNS})
        mode = "reactive" if task.start.reactive else "non-reactive"
        keys = {"policy": name, "mode": mode, "scene": Path(seat.scene).name, "vehicle": seat.vehicle,
                "start_s": seat.start_s}
        if result.video is not None:
            videos[seat_video_name(name, mode, index, task.seed)] = result.video
        desired = np.nan if task.start.controller is None else task.start.controller.desired_mps
        rows.append({**keys, "entry_distance_m": seat.entry_distance_m, "since_entry_s": seat.since_entry_s,
                     **result.metrics, **seat_columns(driven, humans[seat], result.metrics["simulated_s"]),
                     "desired_mps": desired})
        tracks.append(driven.assign(**keys))
    for mode in modes:
        for seat, human in humans.items():
            tracks.append(human.assign(policy=HUMAN, mode=mode, scene=Path(seat.scene).name, vehicle=seat.vehicle,
                                       start_s=seat.start_s))
    metrics = pd.DataFrame(rows)
    overspeed = [float(np.clip(driven["speed_mps"] - limit, 0.0, None).mean()) if len(driven) else 0.0
                 for driven, limit in zip(tracks[:len(rows)], metrics["limit_mps"], strict=True)]
    metrics[list(SCORE_COLUMNS)] = driving_scores(metrics, metrics["human_distance_m"].to_numpy(), np.array(overspeed))
    return Evaluation(metrics, pd.concat(tracks, ignore_index=True), SEATS, videos)


def seat_video_name(driver: str, mode: str, index: int, seed: int) -> str:
    """File name of the video of `driver` in the `index`-th seat in `mode` (`video_name` of "DRIVER MODE")."""
    return video_name(f"{driver} {mode}", index, seed)


SEATS = Tables(SCENE_EPISODES, SCENE_TRACKS, ".tracks.parquet", plain_table, plain_table, seats_summary)
"""What `evaluate_seats` writes: the metrics and NAME.tracks.parquet, each as pandas types it."""


def tracks_path(metrics_path: Path) -> Path:
    """Where the per-decision tracks of a metrics file go: NAME.tracks.parquet beside NAME.parquet."""
    return SEATS.beside(metrics_path)
