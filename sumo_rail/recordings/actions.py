"""The five actions read off a recorded track, one per decision instant of the env's period.

The rule, for the decision at t (the period t .. t + T, T = env.decision_period_s):
1. Lane change. A change of the lane index between two rows is a lane change, to the left when the index grows
   (SUMO's lane 0 is the rightmost). It belongs to the period in which the vehicle began to move sideways toward the
   new lane: from the row where the lane index changes, back while its sideways speed toward the new lane exceeds
   `onset_speed_mps`, at most `onset_lookback_s`. The env's lane-change action starts the manoeuvre in the period
   it is taken, while the lane index changes only when the vehicle's centre crosses the marking, about half of
   scenario.lane_change_duration_s (2 s) later; reading the crossing would put the change about two decisions
   late. In a sweep over two lanes (no pause between the crossings) the look-back stops midway between the two
   crossings, where the second change began (the vehicle passes the middle lane's centre). Without sideways
   positions (`lateral_m` None: a route that is not one edge straight along x) the crossing's own period is used.
   On a network of several edges the lanes are compared in the route frame of the track's edges
   (`scene_observations.in_route_frame`): a change of edge is then no lane change, nor is a lane kept where lanes are
   added or dropped, and a change made at an edges' boundary is one.
2. Otherwise the speed, against an estimated set-point S [m/s] (the env's accelerate and decelerate move the ACC's
   set-point by env.speed_step_mps, and the ACC then drives toward it; what a track shows is the speed). Per period the
   mean acceleration a = (v(t + T) - v(t)) / T. S starts at the first speed and is never below the current speed.
   - An acceleration phase begins at a period with a > `dead_band_mps2` and lasts while a > `phase_floor_mps2`. The
     speed it ends at, v_end, above S says how many set-point steps were added: n = round((v_end - S) / step), at
     least 1 if the phase began at the set-point (v(t) >= S - `set_point_tolerance_mps`), 0 if it began below it and
     ended within the tolerance of S (the ACC catching up on a set-point already there), at most the phase's length.
     The phase's first n periods are accelerate, the rest keep; S rises by n steps.
   - A deceleration phase (a < -`dead_band_mps2`, lasting while a < -`phase_floor_mps2`) that began at the
     set-point is max(1, round(speed lost / step)) decelerates in its first periods, and S drops by as many steps; one
     that began below the set-point is the ACC following a slower leader: keep.
   Thresholds: the dead band is half of what one action does in the env within its period. A set-point step of
   env.speed_step_mps (2 m/s) is closed by SUMO's ACC at the ego type's full acceleration (2.6 m/s^2) or deceleration
   (3.0 m/s^2): one action's mean over its period is min(accel, decel, step / T) = 2.6 m/s^2, the band 1.3 m/s^2
   (`for_env`); a higher band reads the expert better (its steps begin at the ACC's full 2.6 m/s^2) but would read
   a human's gentler speed changes as keep (docs/results/action_rule/expert.md gives the trade-off). The phase floor
   (0.5 m/s^2) and the set-point tolerance (0.5 m/s, a quarter step) lie above what the ACC's cruising wanders by
   (80% of the expert's keeps lie within +-0.2 m/s^2); on the validation episodes, halving or doubling the floor
   moved the speed actions' recall and precision by at most 0.02, the tolerance by up to 0.1 (doubled: more
   car-following read as decelerate).
What the rule cannot see: a set-point step that the speed does not follow. The expert's accelerates come in runs (a
step every 0.5 s adds 4 m/s^2 of set-point, the ACC follows at 2.6) and behind slower leaders; the ACC catching up
on a set-point after a leader leaves its lane looks like an accelerate; a human's gentle speed change (below
1.3 m/s^2) reads as keep however long it lasts. docs/results/action_rule/README.md gives the shares.
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
PHASE_FLOOR_MPS2 = 0.5
"""An acceleration or deceleration phase lasts while the period's mean acceleration beyond this [m/s^2] continues."""
SET_POINT_TOLERANCE_MPS = 0.5
"""A speed within this [m/s] below the estimated set-point is at the set-point (a quarter of the env's step)."""
ONSET_LOOKBACK_S = 3.0
"""The farthest back [s] from the lane index's change a lane change's start is looked for (half a slow human lane
change)."""


@dataclass(frozen=True)
class ActionRule:
    """The thresholds of the rule (module docstring)."""

    decision_period_s: float
    dead_band_mps2: float
    speed_step_mps: float
    phase_floor_mps2: float = PHASE_FLOOR_MPS2
    set_point_tolerance_mps: float = SET_POINT_TOLERANCE_MPS
    onset_speed_mps: float = ONSET_SPEED_MPS
    onset_lookback_s: float = ONSET_LOOKBACK_S

    @classmethod
    def for_env(cls, env: EnvConfig) -> ActionRule:
        """The rule for the env's period and set-point step and the ego type's acceleration limits: the dead band is
        half of one action's mean acceleration over its period, min(accel, decel, step / T)."""
        accel_mps2, decel_mps2 = ego_limits()
        period = env.decision_period_s
        return cls(period, 0.5 * min(accel_mps2, decel_mps2, env.speed_step_mps / period), env.speed_step_mps)


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
    instants = decision_instants(time_s, rule.decision_period_s)
    if len(instants) == 0:
        return instants, np.zeros(0, dtype=np.int64)
    actions = speed_actions(np.interp(time_s[0] + rule.decision_period_s * np.arange(len(instants) + 1), time_s,
                                      speed_mps), rule)
    for decision, left in lane_changes(time_s, lane, edge, lateral_m, rule, len(instants)):
        actions[decision] = Action.LANE_LEFT if left else Action.LANE_RIGHT
    return instants, actions


def decision_instants(time_s: np.ndarray, period_s: float) -> np.ndarray:
    """The decision instants [s] of a track whose rows are at `time_s` (sorted): every `period_s` from its first row
    while the track lasts one more period."""
    count = math.floor((time_s[-1] - time_s[0]) / period_s + 1e-6)
    return time_s[0] + period_s * np.arange(count)


def lane_changes(time_s: np.ndarray, lane: np.ndarray, edge: np.ndarray, lateral_m: np.ndarray | None,
                 rule: ActionRule, decisions: int) -> list[tuple[int, bool]]:
    """(decision, to the left) of each lane change of a track (rule 1 of the module docstring), the decisions counted
    from its first row in periods of the rule's."""
    period = rule.decision_period_s
    changes = []
    crossings = np.flatnonzero((np.diff(lane) != 0) & (edge[1:] == edge[:-1])) + 1
    previous_s = -math.inf  # the previous crossing [s]
    for row in crossings:
        left = bool(lane[row] > lane[row - 1])
        start_s = _onset(time_s, lateral_m, int(row), left, previous_s, rule) if lateral_m is not None else time_s[row]
        previous_s = time_s[row]
        # the row is the first one that shows it: it happened after the row before, so a row on a decision
        # instant belongs to the period before
        decision = min(math.floor((start_s - time_s[0]) / period - 1e-6), decisions - 1)
        changes.append((max(decision, 0), left))
    return changes


def speed_actions(speeds_mps: np.ndarray, rule: ActionRule) -> np.ndarray:
    """The speed action (an `Action` value) of each period between consecutive decision instants, from the speeds
    [m/s] at the instants (one more than the periods), against the estimated set-point (module docstring, 2.)."""
    return speed_reading(speeds_mps, rule)[0]


def speed_reading(speeds_mps: np.ndarray, rule: ActionRule) -> tuple[np.ndarray, np.ndarray]:
    """`speed_actions` and the estimated set-point S [m/s] at the start of each period (before its action)."""
    acceleration = np.diff(speeds_mps) / rule.decision_period_s
    actions = np.full(len(acceleration), int(Action.KEEP), dtype=np.int64)
    set_points = np.zeros(len(acceleration))
    set_point, tolerance, step = float(speeds_mps[0]), rule.set_point_tolerance_mps, rule.speed_step_mps
    period = 0
    while period < len(acceleration):
        set_point = max(set_point, float(speeds_mps[period]))
        set_points[period] = set_point
        sign = int(np.sign(acceleration[period])) if abs(acceleration[period]) > rule.dead_band_mps2 else 0
        if sign == 0:
            period += 1
            continue
        end = period
        while end < len(acceleration) and sign * acceleration[end] > rule.phase_floor_mps2:
            end += 1
        at_set_point = speeds_mps[period] >= set_point - tolerance
        if sign > 0:
            steps = round((speeds_mps[end] - set_point) / step) if speeds_mps[end] > set_point + tolerance else 0
            steps = min(max(steps, int(at_set_point)), end - period)
            actions[period:period + steps] = Action.ACCELERATE
            set_points[period:end] = set_point + step * np.minimum(np.arange(end - period), steps)
            set_point += steps * step
        elif at_set_point:
            steps = min(max(round((speeds_mps[period] - speeds_mps[end]) / step), 1), end - period)
            actions[period:period + steps] = Action.DECELERATE
            set_points[period:end] = set_point - step * np.minimum(np.arange(end - period), steps)
            set_point -= steps * step
        else:
            set_points[period:end] = set_point
        period = end
    return actions, set_points


def _onset(time_s: np.ndarray, lateral_m: np.ndarray, row: int, left: bool, previous_s: float,
           rule: ActionRule) -> float:
    """The time of the first row that had moved sideways toward the lane entered at `row` [s] (module docstring)."""
    sideways = np.diff(lateral_m) / np.maximum(np.diff(time_s), 1e-9) * (1.0 if left else -1.0)
    start = row
    midway_s = 0.5 * (previous_s + time_s[row])
    earliest_s = max(time_s[row] - rule.onset_lookback_s, midway_s) - 1e-9
    while start - 1 >= 0 and sideways[start - 1] > rule.onset_speed_mps and time_s[start - 1] >= earliest_s:
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
