"""The rule-based expert: privileged, deterministic, in the spirit of IDM/MOBIL, choosing among the five actions.

The expert reads the traffic directly (`HighwayEnv.traffic`: lanes, gaps and speeds of its neighbours), not
the LIDAR. Each decision, in this order:
1. while a lane change is under way it only manages its speed;
2. overtake on the left when a slower leader is in the way, the left lane lets it drive at least
   `min_speed_gain_mps` faster, and the change is safe;
3. otherwise return right when the right lane is free for `keep_right_s` at its desired speed and safe;
4. otherwise move the cruise set-point toward its desired speed (SUMO's ACC keeps the gap to the leader).

A change is safe when nobody is alongside in the target lane, the gap to the new leader is at least
`min_gap_m + front_time_gap_s * v_ego` plus the distance needed to shed any speed excess at 3 m/s^2, and the
gap to the new follower is at least `min_gap_m + rear_time_gap_s * v_follower` plus its braking distance to
the ego's speed. SUMO's own safety check stays on as a second line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sumo_rail.sim.actions import Action
from sumo_rail.sim.traffic import NO_VEHICLE, LaneGaps, TrafficView, lane_gaps, within

_COMFORT_DECEL_MPS2 = 3.0


@dataclass(frozen=True)
class ExpertStyle:
    """How the expert drives. Speeds [m/s], times [s], distances [m]."""

    desired_speed_mps: float
    """Cruise set-point it aims for."""
    min_speed_gain_mps: float
    """Overtakes only when the left lane is at least this much faster than its own lane."""
    look_ahead_s: float
    """A leader closer than this time gap at the desired speed sets its lane's speed."""
    front_time_gap_s: float
    """Time gap it wants to the new leader after a lane change."""
    rear_time_gap_s: float
    """Time gap it leaves to the new follower after a lane change."""
    min_gap_m: float
    """Gap kept in every case, front and rear."""
    keep_right_s: float
    """Returns right only when the right lane is free for this time at the desired speed."""


STYLES: dict[str, ExpertStyle] = {
    "calm": ExpertStyle(desired_speed_mps=28.0, min_speed_gain_mps=2.0, look_ahead_s=4.0, front_time_gap_s=1.5,
                        rear_time_gap_s=1.8, min_gap_m=8.0, keep_right_s=5.0),
    "normal": ExpertStyle(desired_speed_mps=30.5, min_speed_gain_mps=1.5, look_ahead_s=4.0, front_time_gap_s=1.2,
                          rear_time_gap_s=1.5, min_gap_m=6.0, keep_right_s=8.0),
    "sporty": ExpertStyle(desired_speed_mps=33.33, min_speed_gain_mps=1.0, look_ahead_s=3.0, front_time_gap_s=1.0,
                          rear_time_gap_s=1.3, min_gap_m=5.0, keep_right_s=12.0),
}
"""Rear time gaps are at least SUMO's own requirement for the slowest-reacting followers (trucks: tau 1.2 s), so
the expert does not ask for changes that SUMO would refuse."""
DEFAULT_STYLE = "normal"


class Expert:
    """A driver: `expert(observation, traffic) -> action`. The observation is ignored (the expert is privileged)."""

    def __init__(self, style: ExpertStyle, speed_step_mps: float, view_range_m: float = NO_VEHICLE) -> None:
        self.style = style
        self._half_step = 0.5 * speed_step_mps
        self.view_range_m = view_range_m
        """Vehicles farther than this along the road are ignored [m]."""

    def __call__(self, observation: np.ndarray, traffic: TrafficView) -> int:
        return int(self.decide(traffic))

    def decide(self, traffic: TrafficView) -> Action:
        if self.view_range_m < NO_VEHICLE:
            traffic = within(traffic, self.view_range_m)
        ego, style = traffic.ego, self.style
        if not ego.changing_lane:
            own = lane_gaps(traffic, ego.lane)
            own_speed = self._lane_speed(own, style.look_ahead_s)
            if ego.lane + 1 < traffic.lanes and own_speed < style.desired_speed_mps - style.min_speed_gain_mps:
                left = lane_gaps(traffic, ego.lane + 1)
                if (self._lane_speed(left, style.look_ahead_s) >= own_speed + style.min_speed_gain_mps
                        and self._safe(left, ego.speed_mps)):
                    return Action.LANE_LEFT
            if ego.lane > 0:
                right = lane_gaps(traffic, ego.lane - 1)
                if (self._lane_speed(right, style.keep_right_s) >= style.desired_speed_mps - style.min_speed_gain_mps
                        and self._safe(right, ego.speed_mps)):
                    return Action.LANE_RIGHT
        if traffic.set_point_mps < style.desired_speed_mps - self._half_step:
            return Action.ACCELERATE
        if traffic.set_point_mps > style.desired_speed_mps + self._half_step:
            return Action.DECELERATE
        return Action.KEEP

    def _lane_speed(self, gaps: LaneGaps, horizon_s: float) -> float:
        """Speed the ego could hold in a lane: its leader's, if that is within `horizon_s` at the desired speed."""
        desired = self.style.desired_speed_mps
        if gaps.front_gap_m < horizon_s * desired:
            return min(gaps.front_speed_mps, desired)
        return desired

    def _safe(self, gaps: LaneGaps, ego_speed_mps: float) -> bool:
        style = self.style
        if gaps.alongside:
            return False
        excess = max(ego_speed_mps - gaps.front_speed_mps, 0.0) if np.isfinite(gaps.front_speed_mps) else 0.0
        needed_front = style.min_gap_m + style.front_time_gap_s * ego_speed_mps + excess**2 / (2 * _COMFORT_DECEL_MPS2)
        closing = max(gaps.rear_speed_mps - ego_speed_mps, 0.0) if np.isfinite(gaps.rear_speed_mps) else 0.0
        rear_speed = gaps.rear_speed_mps if np.isfinite(gaps.rear_speed_mps) else 0.0
        needed_rear = style.min_gap_m + style.rear_time_gap_s * rear_speed + closing**2 / (2 * _COMFORT_DECEL_MPS2)
        return gaps.front_gap_m >= needed_front and gaps.rear_gap_m >= needed_rear


def make_expert(style_name: str, speed_step_mps: float, view_range_m: float = NO_VEHICLE) -> Expert:
    """The expert of a named style; KeyError-free: an unknown name is a ValueError naming the known styles."""
    if style_name not in STYLES:
        raise ValueError(f"unknown expert style {style_name!r}; known styles: {', '.join(sorted(STYLES))}")
    return Expert(STYLES[style_name], speed_step_mps, view_range_m)
