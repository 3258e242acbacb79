"""One driving score per episode, built as nuPlan's closed-loop score (nuplan-devkit's metric configs): gates that
multiply (at-fault collisions, leaving the road, making progress) times a weighted mean of progress, time to
collision, speed-limit compliance and comfort. Each term is in docs/replay.md."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_LON_ACCEL_MPS2 = -4.05
"""nuPlan's ego_lon_acceleration min_lon_accel [m/s^2]."""
MAX_LON_ACCEL_MPS2 = 2.40
"""nuPlan's ego_lon_acceleration max_lon_accel [m/s^2]."""
MAX_ABS_LON_JERK_MPS3 = 4.13
"""nuPlan's ego_lon_jerk max_abs_lon_jerk [m/s^3]."""
MAX_ABS_JERK_MPS3 = 8.37
"""nuPlan's ego_jerk max_abs_mag_jerk [m/s^3] (here the jerk along the heading: SUMO's lateral motion is a lane
change of fixed duration, so the magnitude is the longitudinal one)."""
LEAST_MIN_TTC_S = 0.95
"""nuPlan's time_to_collision_within_bound least_min_ttc [s]."""
MAX_OVERSPEED_MPS = 2.23
"""nuPlan's speed_limit_compliance max_overspeed_value_threshold [m/s]."""
MIN_PROGRESS_RATIO = 0.2
"""nuPlan's ego_is_making_progress min_progress_threshold (share of the expert's progress)."""
PROGRESS_DISTANCE_THRESHOLD_M = 2.0
"""nuPlan's ego_progress_along_expert_route score_progress_threshold [m]: below it the expert barely moved and the
progress term is 1."""
WEIGHTS = {"progress": 5.0, "ttc": 5.0, "speed_limit": 4.0, "comfort": 2.0}
"""nuPlan's weights of the averaged terms."""


@dataclass(frozen=True)
class EpisodeDriving:
    """What the score needs from one closed-loop episode of the ego (per-step arrays at the simulation step)."""

    step_length_s: float
    speed_mps: np.ndarray
    acceleration_mps2: np.ndarray
    speed_limit_mps: float
    min_ttc_s: float
    """The smallest time to collision with the vehicle ahead over the episode [s] (inf: never closing in)."""
    progress_m: float
    """The ego's distance along the road [m]."""
    reference_progress_m: float
    """The human's (or the reference driver's) distance along the road over the same time [m]."""
    at_fault_collision: bool
    """The ego rear-ended someone or changed lanes into them."""
    left_road: bool


def comfortable(acceleration_mps2: np.ndarray, step_length_s: float) -> bool:
    """nuPlan's ego_is_comfortable on the longitudinal motion: acceleration and jerk within the published bounds."""
    acceleration = np.asarray(acceleration_mps2, dtype=float)
    jerk = np.diff(acceleration) / step_length_s if acceleration.size > 1 else np.zeros(0)
    return bool(acceleration.size == 0 or (acceleration.min() >= MIN_LON_ACCEL_MPS2
                                           and acceleration.max() <= MAX_LON_ACCEL_MPS2
                                           and np.all(np.abs(jerk) <= min(MAX_ABS_LON_JERK_MPS3,
                                                                          MAX_ABS_JERK_MPS3))))


def speed_limit_score(speed_mps: np.ndarray, speed_limit_mps: float, step_length_s: float) -> float:
    """1 - the time integral of the speed above the limit over (MAX_OVERSPEED_MPS x the episode's duration), >= 0."""
    speed = np.asarray(speed_mps, dtype=float)
    if speed.size == 0:
        return 1.0
    over = np.clip(speed - speed_limit_mps, 0.0, None).sum() * step_length_s
    return float(max(0.0, 1.0 - over / (MAX_OVERSPEED_MPS * speed.size * step_length_s)))


def progress_ratio(progress_m: float, reference_progress_m: float) -> float:
    """The ego's progress over the reference's, in [0, 1]; 1 where the reference moved less than the threshold."""
    if reference_progress_m < PROGRESS_DISTANCE_THRESHOLD_M:
        return 1.0
    return float(min(max(progress_m / reference_progress_m, 0.0), 1.0))


def driving_score(episode: EpisodeDriving) -> dict[str, float]:
    """The score and each of its parts (gates in {0, 1}, terms in [0, 1])."""
    progress = progress_ratio(episode.progress_m, episode.reference_progress_m)
    parts = {
        "no_at_fault_collision": 0.0 if episode.at_fault_collision else 1.0,
        "on_road": 0.0 if episode.left_road else 1.0,
        "making_progress": 1.0 if progress >= MIN_PROGRESS_RATIO else 0.0,
        "progress": progress,
        "ttc": 1.0 if episode.min_ttc_s >= LEAST_MIN_TTC_S else 0.0,
        "speed_limit": speed_limit_score(episode.speed_mps, episode.speed_limit_mps, episode.step_length_s),
        "comfort": 1.0 if comfortable(episode.acceleration_mps2, episode.step_length_s) else 0.0,
    }
    gates = parts["no_at_fault_collision"] * parts["on_road"] * parts["making_progress"]
    mean = sum(weight * parts[name] for name, weight in WEIGHTS.items()) / sum(WEIGHTS.values())
    return {"driving_score": gates * mean, **parts}
