"""The five actions read off a recorded track, one per decision instant of the env's period.

The rule, for the decision at t (the period t .. t + T, T = env.decision_period_s):
1. Lane change. A change of the lane index between two rows is a lane change, to the left when the index grows
   (SUMO's lane 0 is the rightmost). It belongs to the period in which the vehicle began to move sideways toward the
   new lane: from the row where the lane index changes, back while its sideways speed toward the new lane exceeds
   `onset_speed_mps`, at most `onset_lookback_s`. The env's lane-change action starts the manoeuvre in the period
   it is taken, while the lane index changes only when the vehicle's centre crosses the marking, about half of
   scenario.lane_change_duration_s (1 s, two decisions) later; reading the crossing would put the change one or
   two decisions late. Without sideways positions (`lateral=False`, a network that is not one straight road along x)
   the crossing's own period is used.
2. Otherwise the speed: the mean acceleration over the period, (v(t + T) - v(t)) / T, against the dead band
   `dead_band_mps2`: above it accelerate, below minus it decelerate, else keep. The dead band is half of what one
   accelerate or decelerate does in the env within its period. Measured on the expert
   (experiments/action_rule_validation.py): a set-point step of env.speed_step_mps (2 m/s) is closed by SUMO's ACC
   at the ego type's full acceleration (2.6 m/s^2) or deceleration (3.0 m/s^2), the median period of an accelerate
   averages 2.6 m/s^2 and of a decelerate -3.0 m/s^2, while 80% of keeps lie within +-0.2 m/s^2. One action's
   effect is so min(accel, decel, step / T) = 2.6 m/s^2 and the band 1.3 m/s^2 (`for_env`).
What the rule cannot see: the set-point. An ego still closing on its set-point a decision after an accelerate (a step
takes 0.77 s at 2.6 m/s^2, several steps longer) reads as accelerating again, a driver held back by a slower leader
reads from the speed it drives, not the one it wants, and a human's gentle speed change (below 1.3 m/s^2) reads as
keep however long it lasts.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass

import numpy as np
import pandas as pd

from sumo_rail.config import EnvConfig
from sumo_rail.sim.actions import Action
from sumo_rail.sim.network import sources_dir
from sumo_rail.sim.scenarios import EGO_TYPE, VEHICLE_TYPES_FILE

ONSET_SPEED_MPS = 0.2
"""A sideways speed above this [m/s] toward the new lane is a lane change under way (lane keeping wanders at less)."""
ONSET_LOOKBACK_S = 3.0
"""The farthest back [s] from the lane index's change a lane change's start is looked for (half a slow human lane
change)."""


@dataclass(frozen=True)
class ActionRule:
    """The thresholds of the rule (module docstring)."""

    decision_period_s: float
    dead_band_mps2: float
    onset_speed_mps: float = ONSET_SPEED_MPS
    onset_lookback_s: float = ONSET_LOOKBACK_S

    @classmethod
    def for_env(cls, env: EnvConfig) -> ActionRule:
        """The rule for the env's period and set-point step and the ego type's acceleration limits: the dead band is
        half of one action's mean acceleration over its period, min(accel, decel, step / T)."""
        accel_mps2, decel_mps2 = ego_limits()
        period = env.decision_period_s
        return cls(period, 0.5 * min(accel_mps2, decel_mps2, env.speed_step_mps / period))


def ego_limits() -> tuple[float, float]:
    """The ego vehicle type's acceleration and deceleration [m/s^2], at which SUMO's ACC closes a set-point step."""
    root = ElementTree.fromstring((sources_dir() / VEHICLE_TYPES_FILE).read_bytes())
    ego = next(vtype for vtype in root.iter("vType") if vtype.get("id") == EGO_TYPE)
    return float(ego.get("accel", "2.6")), float(ego.get("decel", "4.5"))


def read_track(time_s: np.ndarray, speed_mps: np.ndarray, lane: np.ndarray, edge: np.ndarray,
               lateral_m: np.ndarray | None, rule: ActionRule) -> tuple[np.ndarray, np.ndarray]:
    """The decision instants [s] of one track (sorted rows: times [s], speeds [m/s], lane indices, edges and, where
    known, the sideways position [m], left positive) and the action (an `Action` value) read at each. Lane indices
    are compared on one edge only: onto the next edge the index may shift with the lane count."""
    period = rule.decision_period_s
    count = math.floor((time_s[-1] - time_s[0]) / period + 1e-6)
    instants = time_s[0] + period * np.arange(count)
    if count == 0:
        return instants, np.zeros(0, dtype=np.int64)
    acceleration = (np.interp(instants + period, time_s, speed_mps) - np.interp(instants, time_s, speed_mps)) / period
    actions = np.where(acceleration > rule.dead_band_mps2, Action.ACCELERATE,
                       np.where(acceleration < -rule.dead_band_mps2, Action.DECELERATE, Action.KEEP)).astype(np.int64)
    crossings = np.flatnonzero((np.diff(lane) != 0) & (edge[1:] == edge[:-1])) + 1
    for row in crossings:
        left = lane[row] > lane[row - 1]
        start_s = _onset(time_s, lateral_m, row, left, rule) if lateral_m is not None else time_s[row]
        # the row is the first one that shows it: it happened after the row before, so a row on a decision
        # instant belongs to the period before
        decision = min(math.floor((start_s - time_s[0]) / period - 1e-6), count - 1)
        actions[max(decision, 0)] = Action.LANE_LEFT if left else Action.LANE_RIGHT
    return instants, actions


def _onset(time_s: np.ndarray, lateral_m: np.ndarray, row: int, left: bool, rule: ActionRule) -> float:
    """The time of the first row that had moved sideways toward the lane entered at `row` [s] (module docstring)."""
    sideways = np.diff(lateral_m) / np.maximum(np.diff(time_s), 1e-9) * (1.0 if left else -1.0)
    start = row
    while (start - 1 >= 0 and sideways[start - 1] > rule.onset_speed_mps
           and time_s[row] - time_s[start - 1] <= rule.onset_lookback_s + 1e-9):
        start -= 1
    return float(time_s[min(start + 1, row)])  # the first row that has moved


def read_actions(tracks: pd.DataFrame, rule: ActionRule, lateral: bool) -> pd.DataFrame:
    """vehicle_id, time_s (decision instant) and action of every decision of every track of a scene (rows of
    `scene.TRACK_COLUMNS`); `lateral`: the scene's road is straight along x, so y is the sideways position (highD,
    NGSIM and the package's straight highway)."""
    parts = []
    for vehicle, track in tracks.sort_values(["vehicle_id", "time_s"], kind="stable").groupby("vehicle_id", sort=True):
        instants, actions = read_track(track["time_s"].to_numpy(), track["speed_mps"].to_numpy(),
                                       track["lane"].to_numpy(), track["edge"].to_numpy(),
                                       track["y_m"].to_numpy() if lateral else None, rule)
        parts.append(pd.DataFrame({"vehicle_id": vehicle, "time_s": instants, "action": actions}))
    if not parts:
        return pd.DataFrame({"vehicle_id": pd.Series(dtype=str), "time_s": pd.Series(dtype=float),
                             "action": pd.Series(dtype=np.int64)})
    return pd.concat(parts, ignore_index=True)
