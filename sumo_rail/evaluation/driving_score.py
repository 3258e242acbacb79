"""One driving score per episode, built as nuPlan's closed-loop score (nuplan-devkit, docs/metrics_description.md and
the simulation metric config; Caesar et al., "nuPlan", 2021; Karnchanachari et al., ICRA 2024):

    score = no_collision x on_road x route_completed x making_progress
            x (5 progress + 5 ttc_compliant + 4 speed_limit_compliance + 2 comfortable) / 16

Gates (0 or 1, multiplying):
- no_collision: nuPlan's no_ego_at_fault_collisions. The generated roads' env does not say who caused a collision,
  so there every collision of the ego counts as at fault; a recorded scene's episodes have `at_fault_collisions`
  (the ego ran into the other, `scene_evaluation`), which is then used (nuPlan gives 0.5 for a collision with a
  static object; there are none).
- on_road: nuPlan's drivable_area_compliance. The env refuses a lane change off the road (an invalid action that
  does nothing), so its ego cannot leave the road: 1 unless the metrics have a boolean `off_road` column (a
  recorded scene may set it).
- route_completed: the failed manoeuvre, nuPlan's driving along the route: 0 after a missed exit or a stop at a lane
  end (`sumo_rail.sim.route_progress`).
- making_progress: nuPlan's ego_is_making_progress: the progress ratio at least `MIN_PROGRESS_RATIO`.
Weighted terms (weights 5, 5, 4, 2: nuPlan's ego_progress_along_expert_route, time_to_collision_within_bound,
speed_limit_compliance, ego_is_comfortable):
- progress: the distance driven over the reference's in the same episode (the expert's, or the human's in a recorded
  scene), capped at 1; 1 when the reference did not move.
- ttc_compliant: no decision with a time to collision below nuPlan's least_min_ttc, `TTC_BOUND_S` (from the episode's
  `min_ttc_s`, read at every decision rather than nuPlan's 0.1 s steps).
- speed_limit_compliance: 1 - (time-mean overspeed) / `MAX_OVERSPEED_MPS`, floored at 0, as nuPlan's; the overspeed
  is the ego's speed above the road's limit at each decision.
- comfortable: nuPlan's ego_is_comfortable on what the env reads: the longitudinal deceleration within nuPlan's
  -4.05 m/s^2 (the env's `hard_braking` count, at its threshold `env.hard_brake_mps2`, 4 m/s^2 by default), and the
  longitudinal jerk within `MAX_ABS_LON_JERK_MPS3`, taken on the episode's mean absolute jerk `jerk_mean_mps3`:
  SUMO sets a new acceleration at every 0.1 s step without actuator dynamics, so the step-to-step maximum
  (`jerk_max_mps3`, some 56 m/s^3 for the expert) is not comparable with nuPlan's jerk, which is smoothed
  (Savitzky-Golay) first. Lateral acceleration, yaw rate and yaw acceleration (nuPlan's other comfort limits) have no
  reading in the env (a SUMO lane change has no lateral dynamics) and are left out, as is the upper acceleration
  limit (2.40 m/s^2: no per-episode reading).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

TTC_BOUND_S = 0.95
"""nuPlan's least_min_ttc: a time to collision below this fails time_to_collision_within_bound [s]."""
MAX_OVERSPEED_MPS = 2.23
"""nuPlan's max_overspeed_value_threshold: a time-mean overspeed of this scores 0 [m/s]."""
MAX_ABS_LON_JERK_MPS3 = 4.13
"""nuPlan's max_abs_lon_jerk [m/s^3]."""
MIN_LON_ACCEL_MPS2 = -4.05
"""nuPlan's min_lon_accel (read through the env's hard braking count) [m/s^2]."""
MIN_PROGRESS_RATIO = 0.2
"""nuPlan's ego_is_making_progress threshold on the progress ratio."""
WEIGHTS = {"progress": 5.0, "ttc_compliant": 5.0, "speed_limit_compliance": 4.0, "comfortable": 2.0}
"""nuPlan's weights of the closed-loop score's weighted mean."""
GATES = ("no_collision", "on_road", "route_completed", "making_progress")
SCORE_COLUMNS = ("driving_score", *GATES, *WEIGHTS)
"""Episode columns of the driving score and its parts, in table order."""


def driving_scores(episodes: pd.DataFrame, reference_distance_m: np.ndarray,
                   mean_overspeed_mps: np.ndarray) -> pd.DataFrame:
    """SCORE_COLUMNS for each episode of `episodes` (metrics rows with `collisions` or `at_fault_collisions`,
    `missed_exits`, `lane_end_stops`, `distance_m`, `min_ttc_s`, `hard_braking`, `jerk_mean_mps3`, optionally
    `off_road`), given the reference's distance in the same episode [m] and the ego's time-mean speed above the
    limit [m/s]."""
    distance = episodes["distance_m"].to_numpy(dtype=float)
    reference = np.asarray(reference_distance_m, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        progress = np.where(reference > 0, np.clip(distance / reference, 0.0, 1.0), 1.0)
    off_road = episodes["off_road"].to_numpy(dtype=bool) if "off_road" in episodes else np.zeros(len(episodes), bool)
    parts = {
        "no_collision": episodes["at_fault_collisions" if "at_fault_collisions" in episodes else "collisions"]
        .to_numpy() == 0,
        "on_road": ~off_road,
        "route_completed": (episodes["missed_exits"].to_numpy() + episodes["lane_end_stops"].to_numpy()) == 0,
        "making_progress": progress >= MIN_PROGRESS_RATIO,
        "progress": progress,
        "ttc_compliant": episodes["min_ttc_s"].to_numpy(dtype=float) >= TTC_BOUND_S,
        "speed_limit_compliance": np.clip(1.0 - np.asarray(mean_overspeed_mps, dtype=float) / MAX_OVERSPEED_MPS,
                                          0.0, 1.0),
        "comfortable": (episodes["hard_braking"].to_numpy() == 0)
        & (episodes["jerk_mean_mps3"].to_numpy(dtype=float) <= MAX_ABS_LON_JERK_MPS3),
    }
    frame = pd.DataFrame({name: np.asarray(values, dtype=float) for name, values in parts.items()},
                         index=episodes.index)
    weighted = sum(weight * frame[name] for name, weight in WEIGHTS.items()) / sum(WEIGHTS.values())
    frame.insert(0, "driving_score", frame[list(GATES)].prod(axis=1) * weighted)
    return frame[list(SCORE_COLUMNS)]


def reference_distances(metrics: pd.DataFrame) -> np.ndarray:
    """Each episode's reference distance [m]: that of the driver its `reference` column names (the expert it was
    compared with) on the same seed, where that driver was evaluated; else the longest any evaluated driver drove on
    that seed (a reference nobody beats, as NAVSIM's PDM score takes the best of ego and PDM-Closed)."""
    by_driver = metrics.groupby(["policy", "seed"])["distance_m"].first()
    best = metrics.groupby("seed")["distance_m"].max()
    named = metrics["reference"] if "reference" in metrics else pd.Series(None, index=metrics.index, dtype=object)
    return np.array([by_driver.get((reference, seed), best[seed]) if isinstance(reference, str) else best[seed]
                     for reference, seed in zip(named, metrics["seed"], strict=True)], dtype=float)


def mean_overspeed(decisions: pd.DataFrame, metrics: pd.DataFrame, speed_limit_mps: float) -> np.ndarray:
    """Each metrics row's time-mean speed above `speed_limit_mps` over its decisions (`speed_mps`, evenly spaced)
    [m/s], matched on (policy, episode); 0 for an episode without decisions."""
    over = (decisions["speed_mps"] - speed_limit_mps).clip(lower=0.0)
    means = over.groupby([decisions["policy"], decisions["episode"]]).mean()
    return np.array([means.get((policy, episode), 0.0)
                     for policy, episode in zip(metrics["policy"], metrics["episode"], strict=True)], dtype=float)
