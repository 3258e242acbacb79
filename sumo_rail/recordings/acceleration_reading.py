"""The acceleration interface's actions (`[actions] interface = "acceleration"`) read off a recorded track.

For the decision at t (the period t .. t + T, T = env.decision_period_s):
1. The acceleration is the period's mean, (v(t + T) - v(t)) / T, from the track's speeds interpolated at the two
   instants: the one constant acceleration that takes the env's ego from the recorded speed at t to the recorded
   speed at t + T (SUMO holds a commanded acceleration through the period), in the interface's nearest bin, clipped to
   its range. There is no dead band: a gentle speed change is read as the gentle acceleration it is. The speed is
   what the env reproduces, so the speed is what is read, in every format: a track's own recorded accelerations
   (highD's, FCD's) integrate to the same mean up to the rows' rounding, and FCD's add up to it only where the file
   holds every SUMO step (a row's acceleration is its last step's). NGSIM's speeds are derived from positions in feet
   and are noisy: with `smoothing_s` > 0 the speeds are first smoothed by a centred moving average over that time.
   Validated on the expert's, a random driver's and SUMO's drivers' own tracks written in each format
   (docs/results/acceleration_reading/README.md): RMS error at most 0.008 m/s^2 (FCD) and 0.040 m/s^2 (highD, whose
   25 Hz frames straddle every other instant); on NGSIM's noise-free round trip the 1 s smoothing costs 0.14 to
   0.75 m/s^2 RMS, the price of the noise it takes out of real NGSIM speeds, which no track here has.
2. The lane decision is rule 1 of `sumo_rail.recordings.actions` (the onset of sideways motion toward the new
   lane), so a period in which a lane change began is that change with the period's acceleration.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from sumo_rail.action_config import ActionConfig
from sumo_rail.recordings.actions import ActionRule, decision_instants, lane_changes
from sumo_rail.recordings.formats import FORMATS
from sumo_rail.sim.actions import Lateral, acceleration_action


def smoothing_for(format_name: str) -> float:
    """The smoothing [s] the speeds of a scene of `format_name` need: its format's `speed_smoothing_s` (NGSIM's, whose
    speeds are derived from positions in feet; none for highD's, FCD's and SUMO's, measured or exact)."""
    form = FORMATS.get(format_name)
    return form.speed_smoothing_s if form is not None else 0.0


def period_accelerations(time_s: np.ndarray, speed_mps: np.ndarray, instants_s: np.ndarray, period_s: float,
                         smoothing_s: float = 0.0) -> np.ndarray:
    """The mean acceleration [m/s^2] of each period that starts at one of `instants_s` [s], from a track's rows (times
    [s], sorted, and speeds [m/s]); with `smoothing_s` > 0 the speeds are first averaged over that time, centred."""
    if smoothing_s > 0.0 and len(time_s) > 1:
        rows = max(1, round(smoothing_s / float(np.median(np.diff(time_s)))))
        speed_mps = uniform_filter1d(np.asarray(speed_mps, dtype=np.float64), rows, mode="nearest")
    ends = np.interp(time_s[0] + period_s * np.arange(len(instants_s) + 1), time_s, speed_mps)
    return np.diff(ends) / period_s


def read_acceleration_track(time_s: np.ndarray, speed_mps: np.ndarray, lane: np.ndarray, edge: np.ndarray,
                            lateral_m: np.ndarray | None, rule: ActionRule, interface: ActionConfig,
                            smoothing_s: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The decision instants [s] of one track (rows as `actions.read_track` takes them), the acceleration-interface
    action read at each and the period's mean acceleration [m/s^2] before it was put in a bin (none for a track shorter
    than one period)."""
    instants = decision_instants(time_s, rule.decision_period_s)
    if len(instants) == 0:
        return instants, np.zeros(0, dtype=np.int64), np.zeros(0)
    accelerations = period_accelerations(time_s, speed_mps, instants, rule.decision_period_s, smoothing_s)
    laterals = np.full(len(instants), int(Lateral.KEEP))
    for decision, left in lane_changes(time_s, lane, edge, lateral_m, rule, len(instants)):
        laterals[decision] = Lateral.LEFT if left else Lateral.RIGHT
    actions = np.array([acceleration_action(interface.nearest_bin(float(acceleration)), Lateral(lateral), interface)
                        for acceleration, lateral in zip(accelerations, laterals, strict=True)], dtype=np.int64)
    return instants, actions, accelerations
