"""The ego's own recent past, as the observation's history block (`observation.history`): what the driver in the seat
did in the last seconds, from which a learner can tell its desired speed and style.

For k = 1 .. history the block holds, k seconds before the decision: the ego's speed / env.v_max_mps (clipped to
[0, 2], as the observation's own speed), its acceleration / `ACCELERATION_SCALE_MPS2` (clipped to [-1, 1]) and the
lanes it has moved since (its lane then minus its lane now, clipped to [-1, 1]: -1 it has moved left). Values
between two known instants are interpolated (the lane: the earlier instant's). Before the first known instant the
first is repeated: an episode from a warm state knows the ego from its first decision on (its speed, acceleration 0,
its lane), a recorded seat from its track's lead-in.
"""

from __future__ import annotations

import numpy as np

ACCELERATION_SCALE_MPS2 = 9.0
"""The acceleration that reads as -1 or 1 [m/s^2] (SUMO's emergency deceleration)."""
HISTORY_FIELDS = ("speed", "acceleration", "lanes_moved")
"""The history block's values for each second back, in order."""


class EgoPast:
    """The instants [s] the ego was known at, with its speed [m/s], acceleration [m/s^2] and lane then."""

    def __init__(self, time_s: np.ndarray | None = None, speed_mps: np.ndarray | None = None,
                 acceleration_mps2: np.ndarray | None = None, lane: np.ndarray | None = None) -> None:
        empty = np.zeros(0)
        self.time_s = list(empty if time_s is None else np.asarray(time_s, dtype=np.float64))
        self.speed_mps = list(empty if speed_mps is None else np.asarray(speed_mps, dtype=np.float64))
        self.acceleration_mps2 = list(empty if acceleration_mps2 is None else np.asarray(acceleration_mps2,
                                                                                        dtype=np.float64))
        self.lane = list(empty if lane is None else np.asarray(lane, dtype=np.float64))
        if not len(self.time_s) == len(self.speed_mps) == len(self.acceleration_mps2) == len(self.lane):
            raise ValueError("an ego's past needs as many speeds, accelerations and lanes as instants")

    def record(self, time_s: float, speed_mps: float, acceleration_mps2: float, lane: int) -> None:
        """Add the ego's state at `time_s` [s] (later than every instant known)."""
        if self.time_s and time_s <= self.time_s[-1]:
            return  # an instant already known (a seat's lead-in ends where the episode begins)
        self.time_s.append(time_s)
        self.speed_mps.append(speed_mps)
        self.acceleration_mps2.append(acceleration_mps2)
        self.lane.append(float(lane))

    def period_acceleration(self, now_s: float, period_s: float) -> float:
        """The mean acceleration [m/s^2] of the period of `period_s` [s] that ends at `now_s` [s], (v(now) - v(now -
        period)) / period from the known speeds (interpolated), as recorded-demos reads a period
        (`acceleration_reading.period_accelerations`, unsmoothed); 0 when the past does not reach that far back (an
        ego from a warm state)."""
        if not self.time_s or self.time_s[0] > now_s - period_s + 1e-9:
            return 0.0
        before, now = np.interp([now_s - period_s, now_s], self.time_s, self.speed_mps)
        return float((now - before) / period_s)

    def block(self, now_s: float, lane: int, seconds: int, v_max_mps: float) -> np.ndarray:
        """The history block at `now_s` [s] of an ego in `lane` now, `seconds` x 3 float32 values (module
        docstring)."""
        block = np.zeros(3 * seconds, dtype=np.float32)
        if seconds == 0 or not self.time_s:
            return block
        times = np.asarray(self.time_s)
        back = now_s - np.arange(1, seconds + 1, dtype=np.float64)
        speed = np.interp(back, times, self.speed_mps)
        acceleration = np.interp(back, times, self.acceleration_mps2)
        earlier = np.clip(np.searchsorted(times, back + 1e-9, side="right") - 1, 0, len(times) - 1)
        moved = np.asarray(self.lane)[earlier] - lane
        block[0::3] = np.clip(speed / v_max_mps, 0.0, 2.0)
        block[1::3] = np.clip(acceleration / ACCELERATION_SCALE_MPS2, -1.0, 1.0)
        block[2::3] = np.clip(moved, -1.0, 1.0)
        return block
