"""Drivers in recorded drivers' seats (closed loop): each driver takes each chosen held-out vehicle's place in its
scene (`sumo_rail.recordings.seat.SceneEnv`) for a fixed horizon, non-reactive or reactive, and is measured against
that vehicle's recorded track. SUMO's IDM may take the seat with its own parameters (`SumoDriver()`, "sumo-idm") or
those calibrated on the scene's train split (`calibrated_sumo_driver`, "sumo-idm-calibrated"; its desired speed, read
from the seated driver's lead-in, is the episode's `desired_mps`).

A seat is a held-out passenger car (the ego is a car) whose track covers `lead_s` + `horizon_s` [s]; the ego starts
`lead_s` after the track begins (the car is fully on the road and has moved with its traffic). Per episode: the
paper's metrics, the safety measures (`safety.SafetyProbe`), the position error against the human's track at 1, 5 and
10 s (`human_likeness`), collisions and those the ego caused (SUMO names the ego the collider: it ran into the
other; a replayed vehicle running into the ego from behind is the other's fault), a stop (speed below
`STOP_MPS`), the progress relative to the human (distances along the road over the same time), lane changes per km
and the driving score with its parts (`driving_score`; the human's distance is the reference's). Per decision, for the
distributions: the ego's and, once per seat, the human's time, position, speed, lane and gap to the leader in its lane.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS, driving_scores
from sumo_rail.evaluation.human_likeness import HORIZONS_S, position_errors
from sumo_rail.evaluation.safety import SafetyProbe
from sumo_rail.recordings.idm import IdmParameters
from sumo_rail.recordings.idm_calibration import IdmCalibration, lead_in_desired_speed
from sumo_rail.recordings.scene import Scene, read_scene
from sumo_rail.recordings.scene_drivers import SEAT_IDM_TYPE, idm_type, seat_calibration
from sumo_rail.recordings.scene_observations import SceneFrames
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.trajectory import TrajectoryPoint, trajectory_frame
from sumo_rail.runners.backends import RolloutBackend, WorkerContext
from sumo_rail.runners.rollout import DriverSpec, KeepDriver, probes_in_turn, run_episode
from sumo_rail.runners.tables import provenance
from sumo_rail.sim.controllers import ActionController, Controller, SumoController
from sumo_rail.sim.replay import NO_TYPES, VehicleTypes
from sumo_rail.sim.traffic import TrafficView, lane_gaps

STOP_MPS = 0.5
"""A speed below this is a stop [m/s]."""
GAP_RANGE_M = 100.0
"""Gaps to a leader beyond this (or none) are no headway sample [m] (the LIDAR's range)."""
HUMAN = "human"
"""The driver name of the recorded vehicles' own rows."""
MODES = {"non-reactive": False, "reactive": True}
SCENE_EPISODES, SCENE_TRACKS = "scene_episodes", "scene_tracks"
"""The `kind` in the provenance of evaluate-scene's two tables."""
ACTIONS = ActionController()
"""The driver's actions drive the ego (every driver but SUMO's)."""


@dataclass(frozen=True)
class SumoDriver:
    """SUMO's IDM and LC2013 in the ego's seat (the env core's "sumo" controller, `SumoController`); the actions are
    not used. Without `idm`, SUMO's IDM parameters and the ego's top set-point as desired speed; with `idm`, each
    scene's calibrated IDM and the desired speed read from the seated driver's lead-in."""

    name: str = "sumo-idm"
    idm: tuple[tuple[str, IdmParameters, float], ...] = ()
    """(scene folder, its calibrated parameters, its train drivers' median desired speed [m/s]) of each scene."""

    def create(self, config: Config, seed: int) -> Callable[[np.ndarray, TrafficView], int]:
        return KeepDriver().create(config, seed)

    def controller(self, scene: Scene, seat: Seat, step_s: float) -> tuple[SumoController, VehicleTypes]:
        """The controller of `seat` in `scene` (SUMO's step `step_s` [s]) and the vehicle type it needs defined."""
        found = {folder: (parameters, typical) for folder, parameters, typical in self.idm}.get(seat.scene)
        if found is None:
            return SumoController(), NO_TYPES
        parameters, typical = found
        desired = lead_in_desired_speed(scene.tracks, seat.vehicle, seat.start_s, parameters, step_s,
                                        typical_mps=typical)
        return SumoController(self.name, SEAT_IDM_TYPE, desired), VehicleTypes({SEAT_IDM_TYPE: idm_type(parameters)})


CALIBRATED_IDM = "sumo-idm-calibrated"
"""The driver name of SUMO's IDM calibrated on each scene's train split."""


def calibrated_sumo_driver(scenes: Sequence[Scene], step_s: float, lead_s: float,
                           horizon_s: float) -> tuple[SumoDriver, dict[str, IdmCalibration]]:
    """SUMO's IDM calibrated on each scene's train seats (`scene_drivers.seat_calibration`) and the calibrations, by
    scene folder; ValueError naming the scene where no IDM can be fitted."""
    calibrations = {str(scene.folder): seat_calibration(scene, step_s, lead_s, horizon_s) for scene in scenes}
    return SumoDriver(CALIBRATED_IDM, tuple((folder, found.parameters, found.desired_mps)
                                            for folder, found in calibrations.items())), calibrations


@dataclass(frozen=True)
class Seat:
    """A recorded vehicle's seat: its scene folder, id and the instant the ego takes it [s]."""

    scene: str
    vehicle: str
    start_s: float


def choose_seats(scene: Scene, split: str, horizon_s: float, lead_s: float, limit: int | None,
                 seed: int) -> list[Seat]:
    """The seats of `split`'s passenger cars whose tracks cover `lead_s` + `horizon_s`, in id order; with `limit`,
    that many drawn without replacement by `seed`, kept in id order."""
    held_out = set(scene.split.loc[scene.split["split"] == split, "vehicle_id"].astype(str))
    spans = scene.tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                                   kind=("vehicle_class", "first"))
    fit = spans[(spans["kind"] == "passenger") & (spans["end"] - spans["begin"] >= lead_s + horizon_s - 1e-9)
                & spans.index.isin(held_out)].sort_index()
    if limit is not None and limit < len(fit):
        fit = fit.iloc[np.sort(np.random.default_rng(seed).choice(len(fit), limit, replace=False))]
    return [Seat(str(scene.folder), str(vehicle), float(begin) + lead_s) for vehicle, begin in fit["begin"].items()]


class _TrackProbe:
    """The ego's state at every decision, the first at `start_s` [s], one every `period_s` [s] (a `DecisionProbe`)."""

    def __init__(self, start_s: float, period_s: float) -> None:
        self.start_s, self.period_s = start_s, period_s
        self.points: list[TrajectoryPoint] = []

    def __call__(self, observation: np.ndarray, traffic: TrafficView, action: int, info: dict[str, Any]) -> None:
        self.add(traffic)

    def add(self, traffic: TrafficView) -> None:
        ego, gap = traffic.ego, lane_gaps(traffic, traffic.ego.lane).front_gap_m
        self.points.append(TrajectoryPoint(self.start_s + len(self.points) * self.period_s, ego.front_x, ego.front_y,
                                           ego.speed_mps, ego.lane, ego.lane_position_m,
                                           gap if gap <= GAP_RANGE_M else np.nan))


def human_track(frames: SceneFrames, seat: Seat, period_s: float, decisions: int) -> pd.DataFrame:
    """The seat's recorded vehicle at the episode's decision instants (`TRAJECTORY_COLUMNS`)."""
    points = []
    for k in range(decisions + 1):
        time_s = seat.start_s + k * period_s
        snapshot = frames.at(time_s)
        row = snapshot.row(seat.vehicle)
        if row is None:
            break
        gap = snapshot.leader_gap_m(row)
        points.append(snapshot.point(row, time_s)._replace(gap_m=gap if gap <= GAP_RANGE_M else np.nan))
    return trajectory_frame(points)


@dataclass(frozen=True)
class SeatTask:
    """One driver's episode in one seat, in one mode (the unit of work of `evaluate_seats`)."""

    config: Config
    seat: Seat
    driver: DriverSpec
    reactive: bool
    seed: int
    types: VehicleTypes = NO_TYPES
    """The vehicle types SUMO knows (the reactive vehicles', `scene_drivers.reactive_types`, and the controller's)."""
    controller: Controller = ACTIONS
    """Who drives the ego: the driver's actions, or SUMO (`SumoDriver.controller`)."""

    def run(self, context: WorkerContext) -> tuple[dict[str, Any], pd.DataFrame]:
        types = self.types
        env = context.custom_env(("scene", self.config, self.seat.scene, self.reactive, types.key),
                                 lambda: SceneEnv(self.config, Path(self.seat.scene), self.reactive,
                                                  transport="libsumo", types=types))
        assert isinstance(env, SceneEnv)
        track, safety = _TrackProbe(self.seat.start_s, env.config.env.decision_period_s), SafetyProbe()
        options = {"vehicle": self.seat.vehicle, "start_s": self.seat.start_s, "controller": self.controller}
        result = run_episode(env, self.driver.create(env.config, self.seed), self.seed, options=options,
                             probe=probes_in_turn(track, safety))
        if result.metrics["termination"] != "collision":
            track.add(env.traffic)
        driven = trajectory_frame(track.points)
        return {**result.metrics, **safety.episode_columns(),
                "at_fault_collisions": sum(collider == "ego" for collider, _ in env.ego_collisions),
                "desired_mps": getattr(self.controller, "desired_mps", None) or np.nan,
                "limit_mps": env.config.scenario.speed_limit_mps}, driven


def seat_columns(driven: pd.DataFrame, human: pd.DataFrame, simulated_s: float) -> dict[str, float]:
    """The measures of one episode against the human's track: position errors, progress, stop, lane changes."""
    errors = position_errors(driven, human) if len(driven) else np.full(len(HORIZONS_S), np.nan)
    start = human["lane_position_m"].iloc[0]
    human_m = float(np.interp(human["time_s"].iloc[0] + simulated_s, human["time_s"], human["lane_position_m"])
                    - start)
    driven_m = float(driven["lane_position_m"].iloc[-1] - driven["lane_position_m"].iloc[0]) if len(driven) else 0.0
    changes = int(np.abs(np.diff(driven["lane"].to_numpy())).sum()) if len(driven) else 0
    return {**{f"position_error_{h:g}s_m": float(e) for h, e in zip(HORIZONS_S, errors, strict=True)},
            "human_distance_m": human_m, "progress_ratio": driven_m / human_m if human_m > 0 else np.nan,
            "stopped": bool(len(driven) and driven["speed_mps"].min() < STOP_MPS),
            "lane_changes_per_km": changes / (driven_m / 1000.0) if driven_m > 0 else np.nan}


def evaluate_seats(drivers: Sequence[DriverSpec], names: Sequence[str], config: Config, seats: Sequence[Seat],
                   modes: Sequence[str], backend: RolloutBackend, seed: int,
                   on_episode: Callable[[int, Any], None] | None = None,
                   reactive_types: Mapping[str, VehicleTypes] | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every driver in every seat in every mode: (one metrics row per episode, one track row per decision with the
    human's rows once per seat and mode under driver `HUMAN`). `reactive_types`: each scene folder's reactive
    vehicles' types (`scene_drivers.reactive_types`; default: SUMO's default Krauss)."""
    scenes = {scene: read_scene(Path(scene)) for scene in {seat.scene: None for seat in seats}}
    step_s, types = config.scenario.step_length_s, reactive_types or {}
    labelled = []
    for mode in modes:
        for driver, name in zip(drivers, names, strict=True):
            for index, seat in enumerate(seats):
                controller, seat_types = (driver.controller(scenes[seat.scene], seat, step_s)
                                          if isinstance(driver, SumoDriver) else (ACTIONS, NO_TYPES))
                scene_types = types.get(seat.scene, NO_TYPES) if MODES[mode] else NO_TYPES
                labelled.append((name, SeatTask(config, seat, driver, MODES[mode], seed + index, VehicleTypes(
                    {**scene_types.definitions, **seat_types.definitions}, scene_types.of_vehicle), controller)))
    tasks = [task for _, task in labelled]
    results = backend.run(tasks, on_result=on_episode)
    frames = {scene: SceneFrames(read.tracks, read.meta.frame_rate_hz) for scene, read in scenes.items()}
    period = config.env.decision_period_s
    horizon_decisions = round(config.env.max_episode_s / period)
    humans = {seat: human_track(frames[seat.scene], seat, period, horizon_decisions) for seat in seats}
    rows, tracks = [], []
    for (name, task), (metrics, driven) in zip(labelled, results, strict=True):
        mode = "reactive" if task.reactive else "non-reactive"
        keys = {"policy": name, "mode": mode, "scene": Path(task.seat.scene).name,
                "vehicle": task.seat.vehicle, "start_s": task.seat.start_s}
        rows.append({**keys, **metrics, **seat_columns(driven, humans[task.seat], metrics["simulated_s"])})
        tracks.append(driven.assign(**keys))
    for mode in modes:
        for seat, human in humans.items():
            tracks.append(human.assign(policy=HUMAN, mode=mode, scene=Path(seat.scene).name, vehicle=seat.vehicle,
                                       start_s=seat.start_s))
    metrics_frame = pd.DataFrame(rows)
    overspeed = [float(np.clip(driven["speed_mps"] - limit, 0.0, None).mean()) if len(driven) else 0.0
                 for driven, limit in zip(tracks[:len(rows)], metrics_frame["limit_mps"], strict=True)]
    metrics_frame[list(SCORE_COLUMNS)] = driving_scores(metrics_frame, metrics_frame["human_distance_m"].to_numpy(),
                                                        np.array(overspeed))
    return metrics_frame, pd.concat(tracks, ignore_index=True)



def tracks_path(metrics_path: Path) -> Path:
    """Where the per-decision tracks of a metrics file go: NAME.tracks.parquet beside NAME.parquet."""
    return Path(metrics_path).with_suffix(".tracks.parquet")


def write_scene_evaluation(metrics: pd.DataFrame, tracks: pd.DataFrame, config: Config, seed: int, out: Path,
                           **extra: Any) -> None:
    """The metrics at `out` and the tracks beside it (`tracks_path`), with provenance, each atomically."""
    write_parquet(pa.Table.from_pandas(metrics, preserve_index=False), out,
                  provenance(SCENE_EPISODES, config, seed, **extra))
    write_parquet(pa.Table.from_pandas(tracks, preserve_index=False), tracks_path(out),
                  provenance(SCENE_TRACKS, config, seed, metrics_file=Path(out).name, **extra))
