"""`sumo-rail recorded-demos`: a scene's tracks as demonstrations in record-expert's schema (`runners.tables`).

Each track of the chosen split is an episode; its decisions are the instants t0 + k T of the env's period T from the
track's first row (`actions.read_track`), as long as the track lasts one more period. At each instant the row holds
the observation the env would give that vehicle (`scene_observations.observe`, the scene's vehicles at that instant,
the cruise set-point estimated by the action rule, `actions.speed_reading`, within [v_min, v_max]) and the action
`ActionRule.for_env` reads; the columns after the action are the env's for the period's end (its speed, lane,
position along the road, the estimated set-point, whether a lane change was under way in the period, and the
rewards the env's formulas give them; no collision). The metadata names the scene (`RECORDED_SCENE`: its files
with their sha256, the source recording's files, the vehicles, the split, the rule's settings and the road's speed
limit, which a learner's configuration must keep, `scene.check_speed_limit`): a recorded driver
cannot be asked what it would do elsewhere, so DAgger refuses such a file (`experts.demonstrations_expert`).

Under the acceleration interface (`actions.interface = "acceleration"`) the action is the acceleration interface's
reading (`acceleration_reading`, NGSIM's speeds smoothed), the set-point's entry of the observation the last
commanded acceleration (0 before the track's first decision, as in the env; a seat taken later shows its lead-in's
last period, as here) and the set-point column the speed. With
`observation.history` the observation ends with the track's own past up to the instant (`sumo_rail.sim.ego_past`),
as the env's seat shows the recorded lead-in.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError, write_parquet
from sumo_rail.recordings.acceleration_reading import read_acceleration_track, smoothing_for
from sumo_rail.recordings.actions import ActionRule, read_track, speed_reading
from sumo_rail.recordings.scene import Scene, check_scene, read_scene, scene_sources
from sumo_rail.recordings.scene_observations import (
    SceneFrames,
    SceneRoad,
    in_route_frame,
    observe,
    route_point,
    scene_routes,
)
from sumo_rail.recordings.trajectory import TrajectoryPoint, track_past
from sumo_rail.runners.experts import RECORDED_SCENE
from sumo_rail.runners.tables import DEMONSTRATIONS, demonstrations_from_columns, provenance
from sumo_rail.sim.actions import split_acceleration_action
from sumo_rail.sim.observation import acceleration_slot, control_slot, observation_space
from sumo_rail.sim.rewards import lateral_reward, longitudinal_reward


@dataclass(frozen=True)
class TrackDecisions:
    """One track's decisions: instants [s], actions, set-points before each action and after the last [m/s] (under
    the acceleration interface the speeds there, what an acceleration of 0 holds), the commanded acceleration each
    decision's observation shows [m/s^2] (the acceleration interface: the previous action's, 0 before the first),
    and the track itself (`past`, for the observation's history block)."""

    vehicle: str
    instants_s: np.ndarray
    actions: np.ndarray
    set_points_mps: np.ndarray
    shown_accelerations_mps2: np.ndarray
    past: pd.DataFrame


def track_decisions(vehicle: str, track: pd.DataFrame, rule: ActionRule, config: Config,
                    smoothing_s: float = 0.0, sideways: float | None = 1.0) -> TrackDecisions:
    """The decisions read off one track (rows sorted by time): the paper's actions by `rule`, with the set-point it
    estimates, or the acceleration interface's (`acceleration_reading`, speeds smoothed over `smoothing_s` [s]);
    `sideways`: y times it is the sideways position, left positive (`SceneRoad.sideways_sign`), which times a lane
    change's onset (None: no sideways position, the crossing is read)."""
    time_s, speed = track["time_s"].to_numpy(), track["speed_mps"].to_numpy()
    lane, edge = track["lane"].to_numpy(), track["edge"].to_numpy()
    lateral = None if sideways is None else sideways * track["y_m"].to_numpy()
    interface = config.actions
    if interface.interface == "acceleration":
        instants, actions, _ = read_acceleration_track(time_s, speed, lane, edge, lateral, rule, interface,
                                                       smoothing_s)
        commanded = [interface.acceleration_mps2(split_acceleration_action(int(a), interface)[0]) for a in actions]
        shown = np.array([0.0, *commanded[:-1]]) if len(actions) else np.zeros(0)
        speeds = np.interp(time_s[0] + rule.decision_period_s * np.arange(len(instants) + 1), time_s, speed)
        return TrackDecisions(vehicle, instants, actions, speeds, shown, track)
    instants, actions = read_track(time_s, speed, lane, edge, lateral, rule)
    speeds = np.interp(np.append(instants, time_s[0] + rule.decision_period_s * len(instants)), time_s, speed)
    set_points = speed_reading(speeds, rule)[1]
    after = set_points[-1] if len(set_points) else speeds[0]
    set_points = np.clip(np.append(set_points, after), config.env.v_min_mps, config.env.v_max_mps)
    return TrackDecisions(vehicle, instants, actions, set_points, np.zeros(len(actions)), track)


def seat_observation(config: Config, observation: np.ndarray, decided: TrackDecisions, step: int, instant_s: float,
                     lane: int) -> np.ndarray:
    """`observe`'s observation at a decision completed as the env's ego sees it: the acceleration interface's
    last commanded acceleration in the set-point's entry, then the history block from the track up to the instant
    (`sumo_rail.sim.ego_past`)."""
    if config.actions.interface == "acceleration" and step < len(decided.shown_accelerations_mps2):
        observation[control_slot(config)] = acceleration_slot(float(decided.shown_accelerations_mps2[step]),
                                                              config.actions)
    if not config.observation.history:
        return observation
    past = track_past(decided.past[decided.past["time_s"] <= instant_s + 1e-9])
    block = past.block(instant_s, lane, config.observation.history, config.env.v_max_mps)
    return np.concatenate([observation, block])


def decisions_table(scene: Scene, road: SceneRoad, config: Config, decisions: list[TrackDecisions],
                    observation_size: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The demonstration columns and observations of `decisions` (one episode each, in order)."""
    frames = SceneFrames(scene.tracks, scene.meta.frame_rate_hz)
    routes = scene_routes(scene.tracks[scene.tracks["vehicle_id"].isin([decided.vehicle for decided in decisions])])
    flag = 2 * config.lidar.beams + 2 + config.scenario.lanes  # the observation's lane-change flag
    wanted: dict[float, list[tuple[int, int]]] = {}
    for episode, decided in enumerate(decisions):
        for step, instant in enumerate(np.append(decided.instants_s, decided.instants_s[-1]
                                                 + config.env.decision_period_s)):
            wanted.setdefault(round(float(instant), 6), []).append((episode, step))
    points: list[dict[int, TrajectoryPoint]] = [{} for _ in decisions]  # the track at each decision, by step
    seen: list[dict[int, np.ndarray]] = [{} for _ in decisions]  # and the observation there
    for instant in sorted(wanted):
        snapshot = frames.at(instant)
        for episode, step in wanted[instant]:
            decided = decisions[episode]
            row = snapshot.row(decided.vehicle)
            assert row is not None  # a decision instant lies within its track
            route = routes[decided.vehicle]
            point = route_point(road, route, snapshot, row, instant)
            seen[episode][step] = seat_observation(config, observe(config, road, *snapshot, decided.vehicle,
                                                                   float(decided.set_points_mps[step]), route),
                                                   decided, step, instant, point.lane)
            points[episode][step] = point
    env, observations, rows = config.env, [], []
    for episode, decided in enumerate(decisions):
        for step, action in enumerate(decided.actions):
            now, after = points[episode][step], points[episode][step + 1]
            changing = bool(seen[episode][step][flag]) or bool(seen[episode][step + 1][flag]) or now.lane != after.lane
            r_long = longitudinal_reward(after.speed_mps, env.v_min_mps, env.v_max_mps)
            r_lat = lateral_reward(changing, env.lane_change_reward)
            observations.append(seen[episode][step])
            rows.append({"episode": episode, "step": step, "episode_seed": -1, "action": int(action),
                         "reward": r_long + r_lat, "reward_longitudinal": r_long, "reward_lateral": r_lat,
                         "reward_collision": 0.0, "speed_mps": after.speed_mps, "lane": after.lane,
                         "position_m": after.lane_position_m, "set_point_mps": float(decided.set_points_mps[step + 1]),
                         "lane_change_in_progress": changing, "terminated": False,  # a recorded track never fails
                         "truncated": step == len(decided.actions) - 1, "termination": "end_of_track"})
    columns = {name: np.array([row[name] for row in rows]) for name in rows[0]}
    return columns, np.stack(observations).reshape(-1, observation_size)


@dataclass(frozen=True)
class RecordedDemosSummary:
    """What a demonstrations file read from a scene holds."""

    tracks: int
    decisions: int
    action_counts: dict[int, int]
    skipped: int
    """Tracks of the split shorter than one decision and the next instant."""


def write_recorded_demos(folder: Path, config: Config, split: str, out: Path) -> RecordedDemosSummary:
    """Read the scene `folder`, compute the demonstrations of its `split` and write them to `out`."""
    scene = read_scene(folder)
    road = check_scene(scene, config, split)
    rule = ActionRule.for_env(config.env)
    vehicles = sorted(scene.split.loc[scene.split["split"] == split, "vehicle_id"].astype(str))
    chosen = scene.tracks[scene.tracks["vehicle_id"].isin(vehicles)].sort_values(["vehicle_id", "time_s"],
                                                                                   kind="stable")
    smoothing_s = smoothing_for(scene.meta.format)
    routes = scene_routes(chosen)
    decisions = [track_decisions(str(vehicle), in_route_frame(road, track, routes[str(vehicle)]), rule, config,
                                 smoothing_s, road.sideways_sign(routes[str(vehicle)]))
                 for vehicle, track in chosen.groupby("vehicle_id", sort=True)]
    kept = [decided for decided in decisions if len(decided.actions)]
    if not kept:
        raise DatasetError(f"no track of the {split} split of {folder} lasts one decision period")
    size = observation_space(config).shape[0]
    columns, observations = decisions_table(scene, road, config, kept, size)
    table = demonstrations_from_columns(columns, observations, size)
    record = {"folder": str(folder.resolve()), "format": scene.meta.format, "files": scene_sources(scene),
              "recording_sources": scene.meta.sources, "split": split,
              "vehicles": [decided.vehicle for decided in kept], "action_rule": dataclasses.asdict(rule),
              "speed_limit_mps": road.speed_limit_mps,
              **({"set_point": "estimated by the action rule, within [env.v_min_mps, env.v_max_mps]"}
                 if config.actions.interface == "paper" else
                 {"acceleration_reading": {"smoothing_s": smoothing_s},
                  "set_point": "the speed at the instant (what an acceleration of 0 holds)"})}
    seed = int(scene.meta.settings.get("split_seed", 0))  # type: ignore[call-overload]
    write_parquet(table, out, provenance(DEMONSTRATIONS, config, seed, driver="recorded drivers",
                                         episodes=len(kept), episode_seeds=[], **{RECORDED_SCENE: record}))
    counts = pd.Series(columns["action"]).value_counts()
    return RecordedDemosSummary(len(kept), len(columns["action"]), {int(k): int(v) for k, v in counts.items()},
                                len(decisions) - len(kept))

