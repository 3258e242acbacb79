"""SUMO's IDM car following in numpy, one SUMO step as SUMO takes it: what `idm_calibration` fits to recorded
drivers and what a SUMO-driven seat then drives with (the calibrated parameters as a vType of the scene's routes).

One step of `next_speed` is SUMO 1.28's, read from its sources (MSCFModel_IDM::_v, followSpeed and freeSpeed;
MSCFModel::finalizeSpeed; the semi-implicit Euler update, SUMO's default), for a vehicle whose action step is the
simulation's step (SUMO's default, the seat's):

- follow speed (a leader at bumper-to-bumper gap s, speed v_l): s* = minGap + max(0, v tau + v (v - v_l) / (2 sqrt(a
  b))), acc = a (1 - (v / v0)^delta - (s* / s)^2), v' = max(0, v + acc dt), in max(1, int(dt / 0.25 + 0.5)) sub-steps
  (idmStepping 0.25 s: one sub-step at dt = 0.1 s) with s reduced by each sub-step's closing;
- free speed: the same without minGap, at a gap of 1e6 m to a "leader" at v0 (at or below v0), or to a standing one at
  an endless road's distance (above v0: SUMO puts the lane's end there; the road is taken as endless);
- the next speed: the lower of the two, kept within [min(v - max(b, 1.5) dt, max(that, v - emergencyDecel dt)),
  v0] (the lower bound wins; speeds never below 0).

v0 is the vehicle's desired speed (SUMO: the lane's limit times its speedFactor, within its type's maxSpeed). SUMO's
IDM has no dawdling (sigma is Krauss's); what it is not: LC2013's speed changes to help or make a lane change.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass

import numpy as np

NUMERICAL_EPS = 0.001
"""SUMO's NUMERICAL_EPS: the smallest gap [m] and desired speed [m/s] the formula divides by."""
IDM_STEPPING_S = 0.25
"""SUMO's default idmStepping [s]: the sub-step of one speed computation."""
FREE_GAP_M = 1e6
"""The gap SUMO's freeSpeed gives IDM below the desired speed [m]."""
EMERGENCY_DECEL_MPS2 = 9.0
"""SUMO's emergencyDecel of a passenger car [m/s^2]: the hardest braking of a step."""


@dataclass(frozen=True)
class IdmParameters:
    """SUMO's IDM parameters (vType attributes accel, decel, tau, minGap, delta); defaults SUMO's own."""

    accel_mps2: float = 2.6
    """Maximum acceleration a [m/s^2]."""
    decel_mps2: float = 4.5
    """Comfortable deceleration b [m/s^2]."""
    tau_s: float = 1.0
    """Desired time headway T [s]."""
    min_gap_m: float = 2.5
    """Standstill gap s0 [m]."""
    delta: float = 4.0
    """Acceleration exponent."""

    def as_array(self) -> np.ndarray:
        """(accel, decel, tau, minGap, delta)."""
        return np.array(astuple(self), dtype=np.float64)

    @classmethod
    def from_array(cls, values: np.ndarray) -> IdmParameters:
        """The parameters of `as_array`'s order."""
        return cls(*(float(value) for value in values))

    def vtype_attributes(self) -> dict[str, str]:
        """The SUMO vType attributes of these parameters (IDM car following)."""
        return {"carFollowModel": "IDM", "accel": repr(self.accel_mps2), "decel": repr(self.decel_mps2),
                "tau": repr(self.tau_s), "minGap": repr(self.min_gap_m), "delta": repr(self.delta)}


SUMO_DEFAULTS = IdmParameters()
"""SUMO's IDM as a vType with carFollowModel="IDM" and nothing else gets it (a passenger car)."""


def _speed(p: IdmParameters, speed: np.ndarray, desired: np.ndarray, gap: np.ndarray, leader_speed: np.ndarray,
           min_gap_m: float, step_s: float) -> np.ndarray:
    """MSCFModel_IDM::_v: the speed after one step behind a leader at `gap` [m] (bumper to bumper) and
    `leader_speed` [m/s], `min_gap_m` added to the desired gap (0 for the free speed)."""
    iterations = max(1, int(step_s / IDM_STEPPING_S + 0.5))
    two_sqrt_ab = 2.0 * np.sqrt(p.accel_mps2 * p.decel_mps2)
    new = speed
    for _ in range(iterations):
        desired_gap = min_gap_m + np.maximum(0.0, new * p.tau_s + new * (new - leader_speed) / two_sqrt_ab)
        gap = np.maximum(NUMERICAL_EPS, gap)
        acc = p.accel_mps2 * (1.0 - (new / np.maximum(NUMERICAL_EPS, desired)) ** p.delta
                              - (desired_gap * desired_gap) / (gap * gap))
        new = np.maximum(0.0, new + acc * step_s / iterations)
        gap = gap - np.maximum(0.0, (new - leader_speed) * step_s / iterations)
    return np.maximum(0.0, new)


def next_speed(p: IdmParameters, speed: np.ndarray, desired: np.ndarray, gap: np.ndarray, leader_speed: np.ndarray,
               step_s: float, emergency_decel_mps2: float = EMERGENCY_DECEL_MPS2) -> np.ndarray:
    """The speed [m/s] after one SUMO step of `step_s` [s] from `speed` with desired speed `desired` [m/s], a leader
    at bumper-to-bumper `gap` [m] (np.inf: none) driving at `leader_speed` [m/s] (arrays of one shape)."""
    speed, desired = np.asarray(speed, dtype=np.float64), np.asarray(desired, dtype=np.float64)
    follow = _speed(p, speed, desired, np.asarray(gap, dtype=np.float64), np.asarray(leader_speed, np.float64),
                    p.min_gap_m, step_s)
    below = speed <= desired
    free = _speed(p, speed, desired, np.where(below, FREE_GAP_M, np.inf), np.where(below, desired, 0.0), 0.0,
                  step_s)
    possible = np.minimum(follow, free)
    braking = max(p.decel_mps2, min(emergency_decel_mps2, 1.5))
    lowest = np.minimum(np.maximum(speed - braking * step_s, 0.0),
                        np.maximum(possible, np.maximum(speed - emergency_decel_mps2 * step_s, 0.0)))
    highest = np.minimum(np.minimum(desired, speed + p.accel_mps2 * step_s), possible)
    return np.maximum(lowest, highest)


def simulate(p: IdmParameters, speed: np.ndarray, desired: np.ndarray, gap: np.ndarray, leader_travel: np.ndarray,
             leader_speed: np.ndarray, step_s: float) -> np.ndarray:
    """N followers driven by SUMO's IDM for H steps behind leaders that move as recorded: their speeds [m/s] after
    each step, (N, H). `speed`, `desired`, `gap` (N,) the start [m/s, m/s, m]; `leader_travel` (N, H) how far each
    leader has moved since the start at the beginning of each step [m] (0 first), `leader_speed` (N, H) its speed
    then [m/s] (np.inf gap: no leader)."""
    speeds = np.empty(leader_speed.shape, dtype=np.float64)
    travelled = np.zeros(len(speed))
    current = np.asarray(speed, dtype=np.float64)
    for k in range(leader_speed.shape[1]):
        current = next_speed(p, current, desired, gap + leader_travel[:, k] - travelled, leader_speed[:, k], step_s)
        travelled = travelled + current * step_s
        speeds[:, k] = current
    return speeds
