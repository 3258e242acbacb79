"""Safety measures of a driver's episode, from SUMO's state (the privileged traffic view read at every decision,
the same the expert reads), never from the LIDAR.

Per decision (in the state the driver decided on):
- time to collision (TTC) [s]: the smallest, over the ego's leader and its follower in the ego's lane, of the
  bumper-to-bumper gap over the speed at which it closes (no closing: no TTC); capped at `TTC_CAP_S`;
- time headway [s]: the gap to the leader in the ego's lane over the ego's speed; capped at `HEADWAY_CAP_S`.
Per decision period, from SUMO's readings at every step (`sumo_rail.sim.period_safety`): the ego's jerk [m/s^3],
and the lowest acceleration [m/s^2] of the followers watched after the ego's cut-ins (the nearest vehicle behind in
the lane the ego changes into, for 3 s from the start of the change).
Per episode: the smallest TTC and headway (the cap when never below it), the share of decisions (of time, as
decisions are evenly spaced) with a TTC below each of `TTC_THRESHOLDS_S`, the share of decisions that were
impossible actions (a lane change off the road), the ego's largest and mean absolute jerk, its cut-ins (lane changes
with a follower in the new lane) and the hardest deceleration of a follower after one (0 without cut-ins).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from sumo_rail.sim.observers import Moment
from sumo_rail.sim.period_safety import NO_READINGS, READINGS
from sumo_rail.sim.traffic import TrafficView, lane_gaps

TTC_THRESHOLDS_S = (1.5, 3.0)
"""TTC below 1.5 s: the critical encounters of traffic-conflict studies; below 3 s: the warning range of forward
collision warning systems (a driver is alerted). [s]"""
TTC_CAP_S = 10.0
"""Times to collision above this (or none: nobody closing) are recorded as this [s]."""
HEADWAY_CAP_S = 10.0
"""Time headways above this are recorded as this [s]."""
_MIN_SPEED_MPS = 0.1
"""Speeds below this count as this in a time headway (a standing ego) [m/s]."""


def time_to_collision(gap_m: float, follower_speed_mps: float, leader_speed_mps: float) -> float:
    """Time until a follower `gap_m` [m] behind its leader's rear reaches it at constant speeds [s]; inf when it
    does not close in (or there is no leader: an infinite gap); 0 when they touch already."""
    if gap_m <= 0.0:
        return 0.0
    closing = follower_speed_mps - leader_speed_mps
    return gap_m / closing if closing > 0.0 and math.isfinite(gap_m) else math.inf


def time_headway(gap_m: float, speed_mps: float) -> float:
    """Time the ego needs at `speed_mps` to cover the gap `gap_m` to its leader [s]; inf without a leader."""
    return gap_m / max(speed_mps, _MIN_SPEED_MPS)


def ego_time_to_collision(traffic: TrafficView) -> float:
    """The ego's smallest TTC in its own lane: to its leader and from its follower [s] (inf: nobody closing)."""
    ego = traffic.ego
    gaps = lane_gaps(traffic, ego.lane)
    return min(time_to_collision(gaps.front_gap_m, ego.speed_mps, gaps.front_speed_mps),
               time_to_collision(gaps.rear_gap_m, gaps.rear_speed_mps, ego.speed_mps))


def ego_time_headway(traffic: TrafficView) -> float:
    """The ego's time headway to its leader in its own lane [s] (inf: no leader seen)."""
    return time_headway(lane_gaps(traffic, traffic.ego.lane).front_gap_m, traffic.ego.speed_mps)


def threshold_column(threshold_s: float) -> str:
    """Episode column of the share of decisions with a TTC below `threshold_s`: ttc_below_1_5s_share..."""
    return f"ttc_below_{threshold_s:g}s_share".replace(".", "_")


SAFETY_MEASURES = ("min_ttc_s", *map(threshold_column, TTC_THRESHOLDS_S), "min_headway_s", "invalid_action_share",
                   "jerk_max_mps3", "jerk_mean_mps3", "cut_ins", "cut_in_follower_decel_mps2")
"""Episode columns of the safety measures, in table order."""
SAFETY_DECISION_FIELDS = ("ttc_s", "jerk_max_mps3", "cut_in_follower_decel_mps2")
"""Per-decision columns: the ego's TTC [s], capped at `TTC_CAP_S`; the period's largest absolute jerk of the ego
[m/s^3]; the hardest deceleration of a follower watched after a cut-in [m/s^2] (NaN: none watched)."""


def episode_measures(ttc_s: np.ndarray, headway_s: np.ndarray, invalid_actions: int,
                     readings: dict[str, np.ndarray] | None = None) -> dict[str, float]:
    """The episode's safety measures from its decisions' TTCs and headways [s] (uncapped; inf: none), its count of
    impossible actions and its periods' `readings` (`sumo_rail.sim.period_safety.READINGS`, one entry a decision;
    none: no period read); an episode without decisions has the caps and zeros."""
    ttc_s, headway_s = np.asarray(ttc_s, dtype=float), np.asarray(headway_s, dtype=float)
    readings = readings or {}
    jerk_max, jerk_mean = (np.asarray(readings.get(name, []), dtype=float) for name in ("jerk_max_mps3",
                                                                                          "jerk_mean_mps3"))
    follower_accel = np.asarray(readings.get("cut_in_follower_accel_mps2", []), dtype=float)
    decisions = len(ttc_s)
    shares = {threshold_column(threshold): float(np.mean(ttc_s < threshold)) if decisions else 0.0
              for threshold in TTC_THRESHOLDS_S}
    return {"min_ttc_s": min(float(ttc_s.min(initial=math.inf)), TTC_CAP_S), **shares,
            "min_headway_s": min(float(headway_s.min(initial=math.inf)), HEADWAY_CAP_S),
            "invalid_action_share": invalid_actions / decisions if decisions else 0.0,
            "jerk_max_mps3": float(jerk_max.max(initial=0.0)),
            "jerk_mean_mps3": float(jerk_mean.mean()) if len(jerk_mean) else 0.0,
            "cut_ins": float(np.sum(readings.get("cut_ins", []))),
            "cut_in_follower_decel_mps2": max(-float(follower_accel.min(initial=np.inf)), 0.0)}


class SafetyObserver:
    """Watches one episode's decisions (an observer of each reset and decision, `sumo_rail.sim.observers`) and keeps
    their safety readings: the traffic each decision was made in, the readings of the period it ran."""

    every_step = False

    def __init__(self) -> None:
        self._ttc_s: list[float] = []
        self._headway_s: list[float] = []
        self._invalid_actions = 0
        self._readings: dict[str, list[float]] = {name: [] for name in READINGS}

    def __call__(self, moment: Moment) -> None:
        for decision in moment.decisions():
            self._ttc_s.append(ego_time_to_collision(decision.traffic))
            self._headway_s.append(ego_time_headway(decision.traffic))
            self._invalid_actions = int(decision.info["invalid_actions"])
            for name, values in self._readings.items():  # a collision's last decision has no period readings
                values.append(decision.info.get(name, NO_READINGS[name]))

    def episode_columns(self) -> dict[str, float]:
        """The episode's SAFETY_MEASURES."""
        readings = {name: np.array(values, dtype=float) for name, values in self._readings.items()}
        return episode_measures(np.array(self._ttc_s), np.array(self._headway_s), self._invalid_actions, readings)

    def decision_columns(self) -> dict[str, np.ndarray]:
        """One entry per decision in each of SAFETY_DECISION_FIELDS."""
        follower_accel = np.array(self._readings["cut_in_follower_accel_mps2"], dtype=np.float64)
        return {"ttc_s": np.minimum(np.array(self._ttc_s, dtype=np.float64), TTC_CAP_S),
                "jerk_max_mps3": np.array(self._readings["jerk_max_mps3"], dtype=np.float64),
                "cut_in_follower_decel_mps2": np.where(np.isinf(follower_accel), np.nan, -follower_accel)}

    def columns(self, env: object, metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """An evaluation observer's record (`protocol.EpisodeObserver`): the SAFETY_MEASURES, SAFETY_DECISION_FIELDS."""
        return self.episode_columns(), self.decision_columns()


@dataclass(frozen=True)
class Safety:
    """Observes each decision's safety readings (`SafetyObserver`): an evaluation's `protocol.ObserverSpec`."""

    def create(self, config: object, seed: int) -> SafetyObserver:
        return SafetyObserver()
