"""The log as DAgger's teacher (training against the log, as CAT-K in Waymo's Sim Agents): a recorded driver cannot be
asked what it would do elsewhere, but its recorded future says where it went, so a state the learner reached in its
seat is labelled with the acceleration-interface action that best returns the ego to the human's track.

The label at time t [s] of an ego at position p [m] along the road, speed v [m/s], in lane l, of a human track whose
read actions are those of `recordings.acceleration_reading` (the decision k whose period holds t):
- Longitudinal: the human's read acceleration a_h of the period, plus the constant correction d that, were the ego to
  follow the human's own accelerations plus d for the next `horizon_s` = H, brings its position and speed at t + H
  closest to the human's (least squares of the position error and H times the speed error, both [m]):
  d = -(2 e_p + 6 e_v H) / (5 H^2), e_p = p - p_h(t), e_v = v - v_h(t); a = a_h + d in the interface's nearest bin,
  clipped to its range. On the human's own state (e_p = e_v = 0) it is the human's read acceleration; behind or slower
  it accelerates more, ahead or faster less. H is the gain: a short horizon returns hard, a long one gently.
- Lateral: in the human's lane at t, the human's read lane decision of the period (a lane change from its onset);
  in another lane, a change toward the human's lane at t + H (its last lane if the track ends sooner); else keep.
What it cannot know: the teacher sees only the seated driver's recorded future, not why it drove so; the other
vehicles replay their tracks (or react otherwise than in the log) once the ego leaves the human's, so a label far
from the track says "go back" whatever the traffic there (it may brake into a gap the human never had, or steer into
a lane now occupied); a state past the track's last decision has no label (`log_label` gives None).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from sumo_rail.action_config import ActionConfig
from sumo_rail.recordings.acceleration_reading import read_acceleration_track
from sumo_rail.recordings.actions import ActionRule
from sumo_rail.sim.actions import Lateral, acceleration_action, split_acceleration_action


@dataclass(frozen=True)
class HumanTrack:
    """A recorded driver's track and the acceleration-interface actions read off it."""

    time_s: np.ndarray
    """The rows' times [s], increasing."""
    position_m: np.ndarray
    """Front bumper's position along the road [m] at each row."""
    speed_mps: np.ndarray
    lane: np.ndarray
    """SUMO's lane index at each row (0 = rightmost)."""
    instants_s: np.ndarray
    """Decision instants [s] (every period from the first row)."""
    laterals: np.ndarray
    """The read lane decision (`Lateral`) of each decision."""
    accelerations_mps2: np.ndarray
    """The read mean acceleration [m/s^2] of each decision's period (before binning)."""
    period_s: float


def read_human_track(track: pd.DataFrame, rule: ActionRule, interface: ActionConfig,
                     smoothing_s: float = 0.0, sideways: float | None = 1.0) -> HumanTrack:
    """One vehicle's rows of a scene (sorted by time) with its read actions (`read_acceleration_track`; `sideways`
    as `recorded_demos.track_decisions` takes it)."""
    time_s, speed = track["time_s"].to_numpy(dtype=float), track["speed_mps"].to_numpy(dtype=float)
    lane = track["lane"].to_numpy()
    lateral = None if sideways is None else sideways * track["y_m"].to_numpy()
    instants, actions, accelerations = read_acceleration_track(time_s, speed, lane, track["edge"].to_numpy(),
                                                               lateral, rule, interface, smoothing_s)
    laterals = np.array([int(split_acceleration_action(int(a), interface)[1]) for a in actions], dtype=np.int64)
    return HumanTrack(time_s, track["lane_position_m"].to_numpy(dtype=float), speed, lane.astype(np.int64),
                      instants, laterals, accelerations, rule.decision_period_s)


def return_acceleration(position_error_m: float, speed_error_mps: float, horizon_s: float) -> float:
    """The constant correction [m/s^2] to the human's accelerations that minimises the squared position error plus the
    squared speed error times the horizon at the horizon [s], given the ego's errors now (ego minus human)."""
    return -(2.0 * position_error_m + 6.0 * speed_error_mps * horizon_s) / (5.0 * horizon_s**2)


def log_label(time_s: float, position_m: float, speed_mps: float, lane: int, human: HumanTrack, horizon_s: float,
              interface: ActionConfig) -> int | None:
    """The action that returns an ego at `time_s` [s], `position_m` [m] along the road, `speed_mps`, in `lane`, to the
    human's track over `horizon_s` [s] (the module docstring); None outside the track's decisions."""
    decision = math.floor((time_s - human.instants_s[0]) / human.period_s + 1e-6) if len(human.instants_s) else -1
    if not 0 <= decision < len(human.instants_s):
        return None
    position_h = float(np.interp(time_s, human.time_s, human.position_m))
    speed_h = float(np.interp(time_s, human.time_s, human.speed_mps))
    acceleration = float(human.accelerations_mps2[decision]) + return_acceleration(position_m - position_h,
                                                                                   speed_mps - speed_h, horizon_s)
    lane_now = _lane_at(human, time_s)
    if lane == lane_now:
        lateral = Lateral(int(human.laterals[decision]))
    else:
        target = _lane_at(human, time_s + horizon_s)
        lateral = Lateral.KEEP if target == lane else (Lateral.LEFT if target > lane else Lateral.RIGHT)
    return acceleration_action(interface.nearest_bin(acceleration), lateral, interface)


def _lane_at(human: HumanTrack, time_s: float) -> int:
    """The human's lane at `time_s` [s]: its last row's at or before it (the last row's after the track)."""
    row = int(np.searchsorted(human.time_s, time_s + 1e-9, side="right")) - 1
    return int(human.lane[min(max(row, 0), len(human.lane) - 1)])
