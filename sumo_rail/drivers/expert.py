"""The rule-based expert: privileged, deterministic, in the spirit of IDM/MOBIL, choosing among the five actions.

The expert reads the traffic directly (`HighwayEnv.traffic`: lanes, gaps and speeds of its neighbours, and its
route as a navigation system tells it), not the LIDAR. Each decision, in this order:
1. while a lane change is under way it only manages its speed;
2. what the route demands: within `route_demand_m` of the end of a lane that does not lead along its route (a lane
   drop, an acceleration lane, lanes past its exit), move toward the nearest lane that does when safe (in the last
   `URGENT_M`, into any gap of its minimum gap and the room to shed a speed difference at 3 m/s^2; in the last
   `LAST_RESORT_M`, at 4 m/s^2), else set its speed to reach a gap there (`Expert._gap_speed`: of all the gaps
   between the vehicles of that lane, long enough for its gaps, the one it reaches soonest, passing vehicles it
   can outpace (no faster than SUMO's ACC drives it behind its own leader) and dropping behind ones it can let
   pass, never slowing down to pass; when none is reached before `URGENT_M` for the last change demanded, the gap
   it would zip merge into, at no more than its desired speed);
3. overtake on the left when a slower leader is in the way, the left lane lets it drive at least
   `min_speed_gain_mps` faster, and the change is safe;
4. otherwise return right when the right lane is free for `keep_right_s` at its desired speed and safe;
   (neither 3 nor 4 into a lane the route would soon demand leaving again)
5. otherwise move the cruise set-point toward its desired speed (SUMO's ACC keeps the gap to the leader).

A change is safe when nobody is alongside in the target lane, the gap to the new leader is at least
`min_gap_m + front_time_gap_s * v_ego` plus the distance needed to shed any speed excess at 3 m/s^2, and the
gap to the new follower is at least `min_gap_m + rear_time_gap_s * v_follower` plus its braking distance to
the ego's speed. For a change the route demands, a slower follower's shorter braking distance counts against that
time gap, and in the zip merge a follower no faster than the ego needs only `ZIP_REAR_GAP_M`. SUMO's own safety
check stays on as a second line (outside the zip merge).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sumo_rail.sim.actions import Action
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.traffic import NO_VEHICLE, LaneGap, LaneGaps, TrafficView, lane_gap_list, lane_gaps, within

_COMFORT_DECEL_MPS2 = 3.0
ROUTE_MARGIN_M = 150.0
"""Distance [m] kept before a lane's end when the route demands leaving it."""
ROUTE_PER_LANE_M = 300.0
"""Distance [m] allowed for each lane change the route demands."""
URGENT_M = 250.0
"""Within this distance [m] of its lane's end the expert zip merges (the environment's `env.zip_merge_m`)."""
URGENT_GAP_SHARE = 0.0
"""Share of its time gaps it keeps when zip merging: none, only its minimum gap and the room to shed a speed
difference (a share of 0.3 in the last 150 m left 17 of 500 test episodes of merge_from_ramp and lane_drop stopped at
a lane's end)."""
LAST_RESORT_M = 50.0
"""Within this distance [m] of its lane's end a change needs only the room to shed closing speeds at
`LAST_RESORT_DECEL_MPS2` beyond its minimum gap: the followers brake harder for it, as SUMO's drivers do for each
other at a lane's end."""
LAST_RESORT_DECEL_MPS2 = 4.0
"""Braking [m/s^2] it counts on from the vehicles around it in the last `LAST_RESORT_M` (SUMO's cars brake at 4.5,
its trucks at 4); elsewhere 3."""
MERGE_SPEED_SHARE = 0.6
"""Lowest set-point, as a share of its desired speed, it slows to while looking for a gap to merge into."""
PASS_MARGIN_MPS = 3.0
"""The least speed difference [m/s] it closes in on the gap it merges into with, and how far above its desired speed
it drives to reach a gap ahead."""
APPROACH_DECEL_MPS2 = 1.0
"""It closes in on the gap it merges into at up to the speed difference it can shed at this rate [m/s^2] by the
middle of the gap, never slower than `PASS_MARGIN_MPS`."""
SPEED_CHANGE_MPS2 = 1.5
"""How fast it reckons it changes its speed when it weighs which gap it reaches soonest [m/s^2]."""
ZIP_REAR_GAP_M = 3.0
"""Least gap [m] it leaves a follower no faster than itself when it zip merges: SUMO's trucks' standstill gap, the
largest of its drivers' (its own `min_gap_m`, 6 m for the normal style, left it 1-5 m ahead of a slower follower,
braked by SUMO for its lane's end until the follower drew alongside again: missed exits, stops at a lane's end)."""
SLOWER_FOLLOWER_BRAKING_MPS2 = 4.5
"""For a change its route demands, it counts a slower follower's shorter braking distance against its time gap, both
braking at this rate [m/s^2] (SUMO's cars'; SUMO's own check of the change counts the same way, with the follower's
reaction time, shorter than the expert's time gaps): 1.5 s behind it at 31 m/s with its 52 m, a follower from the
left lane it was leaving kept it there for 250 m while it pulled away at 1-2 m/s, and then too late for the next
change (exits from the leftmost lanes, missed)."""
LANE_END_BRAKING_MPS2 = 3.0
"""SUMO brakes the ego for the end of its lane at its type's deceleration [m/s^2]: d metres before the end it drives
at most sqrt(2 x this x d)."""
ACC_FOLLOW_M = 120.0
"""Within this gap [m] to its own leader SUMO's ACC model (the ego's) may be in its gap-control mode."""
ACC_CLOSING_PER_S = 0.05
"""In gap control SUMO's ACC drives faster than its leader by this share of its spacing error per second [1/s]
(its gap-closing gains 0.04 / 0.8): it hardly outpaces a leader, however high its set-point."""
ACC_TIME_GAP_S = 1.0
"""Time gap [s] SUMO's ACC keeps (the ego's type's tau) beyond the ego's standstill gap `ACC_MIN_GAP_M`."""
ACC_MIN_GAP_M = 2.5
"""The ego type's standstill gap [m]."""


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


@dataclass(frozen=True)
class Seeker:
    """The ego as it seeks a gap in the lane its route demands."""

    speed_mps: float
    length_m: float
    own: LaneGaps
    """The gaps of its own lane: it never moves up past its leader there."""
    lane_end_m: float = NO_VEHICLE
    """How far its lane leads along its route [m]."""

    def top_speed(self) -> float:
        """The fastest [m/s] SUMO's ACC drives it behind its own leader: the leader's speed plus `ACC_CLOSING_PER_S`
        of its spacing error when the leader is within `ACC_FOLLOW_M`, else no bound."""
        if self.own.front_gap_m > ACC_FOLLOW_M:
            return np.inf
        spacing_error_m = self.own.front_gap_m - ACC_MIN_GAP_M - ACC_TIME_GAP_S * self.speed_mps
        return self.own.front_speed_mps + ACC_CLOSING_PER_S * max(spacing_error_m, 0.0)

    def can_gain(self, gain_m: float, other_mps: float, top_mps: float) -> bool:
        """Whether it gains `gain_m` [m] on a vehicle at `other_mps` [m/s] before SUMO's braking for its lane's end
        holds it below that speed: from its speed toward `top_mps` [m/s] at `SPEED_CHANGE_MPS2` until that braking
        (`LANE_END_BRAKING_MPS2`) reaches it, then along it."""
        if not np.isfinite(self.lane_end_m):
            return True
        accel, braking, start_mps = SPEED_CHANGE_MPS2, LANE_END_BRAKING_MPS2, self.speed_mps
        # where speeding up at `accel` meets the braking curve v^2 = 2 x braking x (distance to the end)
        meet_mps = np.sqrt((braking * start_mps**2 + 2 * accel * braking * self.lane_end_m) / (accel + braking))
        peak_mps = min(top_mps, meet_mps, np.sqrt(2 * braking * self.lane_end_m))
        if peak_mps <= other_mps:
            return False
        change_m, change_s = abs(peak_mps**2 - start_mps**2) / (2 * accel), abs(peak_mps - start_mps) / accel
        cruise_m = max(self.lane_end_m - peak_mps**2 / (2 * braking) - change_m, 0.0)
        brake_m, brake_s = (peak_mps**2 - other_mps**2) / (2 * braking), (peak_mps - other_mps) / braking
        driven_m = change_m + cruise_m + brake_m
        return driven_m - other_mps * (change_s + cruise_m / peak_mps + brake_s) >= gain_m


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
        route = ego.route
        if not ego.changing_lane:
            if route is not None:
                demanded = self._route_change(traffic, route)
                if demanded is not None:
                    return demanded
            lowest, highest = (0, traffic.lanes - 1) if route is None else (route.lowest_lane, route.highest_lane)
            own = lane_gaps(traffic, ego.lane)
            own_speed = self._lane_speed(own, style.look_ahead_s)
            if (ego.lane < highest and own_speed < style.desired_speed_mps - style.min_speed_gain_mps
                    and _leads_on(route, ego.lane + 1)):
                left = lane_gaps(traffic, ego.lane + 1)
                if (self._lane_speed(left, style.look_ahead_s) >= own_speed + style.min_speed_gain_mps
                        and self._safe(left, ego.speed_mps)):
                    return Action.LANE_LEFT
            if ego.lane > lowest and _leads_on(route, ego.lane - 1):
                right = lane_gaps(traffic, ego.lane - 1)
                if (self._lane_speed(right, style.keep_right_s) >= style.desired_speed_mps - style.min_speed_gain_mps
                        and self._safe(right, ego.speed_mps)):
                    return Action.LANE_RIGHT
        if traffic.set_point_mps < style.desired_speed_mps - self._half_step:
            return Action.ACCELERATE
        if traffic.set_point_mps > style.desired_speed_mps + self._half_step:
            return Action.DECELERATE
        return Action.KEEP

    def _route_change(self, traffic: TrafficView, route: RouteView) -> Action | None:
        """The route's demand, before any wish of its own: within `route_demand_m` of the end of a lane that does not
        lead along the route, move toward the nearest lane that does when safe (nearer the end, with the time gaps
        shrunk to `URGENT_GAP_SHARE`), else set its speed to reach the gap it chooses there (`_gap_speed`). None:
        nothing demanded now."""
        ego = traffic.ego
        offset = route.best_lane_offset(ego.lane)
        lane_end_m = route.lane_end(ego.lane)
        if offset == 0 or lane_end_m > route_demand_m(offset):
            return None
        target = ego.lane + (1 if offset > 0 else -1)
        if not route.lowest_lane <= target <= route.highest_lane:
            return None  # the lane to move to begins farther on (an on-ramp before its acceleration lane)
        gaps = lane_gaps(traffic, target)
        share = URGENT_GAP_SHARE if lane_end_m <= URGENT_M else 1.0
        braking = LAST_RESORT_DECEL_MPS2 if lane_end_m <= LAST_RESORT_M else _COMFORT_DECEL_MPS2
        if self._safe(gaps, ego.speed_mps, share, braking, route_demanded=True):
            return Action.LANE_LEFT if offset > 0 else Action.LANE_RIGHT
        own = lane_gaps(traffic, ego.lane)
        # lining up for the zip merge is for the last change only: earlier ones need their gaps before it (exit 6000:
        # from the leftmost lane, 18148/49 and 18340/113 missed the exit)
        zip_in_s = np.inf  # inf: no lining up
        if abs(offset) == 1 and share > URGENT_GAP_SHARE:
            zip_in_s = max(lane_end_m - URGENT_M, 0.0) / max(ego.speed_mps, 1.0)
        seeker = Seeker(ego.speed_mps, ego.length_m, own, lane_end_m)
        target_mps = self._gap_speed(lane_gap_list(traffic, target), seeker, share, zip_in_s)
        return self._toward(target_mps, traffic.set_point_mps)

    def _gap_speed(self, gaps: list[LaneGap], seeker: Seeker, gap_share: float, zip_in_s: float = np.inf) -> float:
        """The set-point [m/s] that takes it to the gap of the lane the route demands that it reaches soonest (its
        time gaps scaled by `gap_share`): forward at up to `PASS_MARGIN_MPS` above its desired speed, but not past its
        own leader nor faster than its ACC outpaces that leader, and only past a vehicle it can pass before SUMO's
        braking for its lane's end holds it back (`Seeker`), or back down to `MERGE_SPEED_SHARE` of it. With no gap
        in reach there, it drops back at any speed. When it reaches no such gap within `zip_in_s` [s], the time until
        it zip merges, it lines up with the gap it would zip merge into (its time gaps scaled by `URGENT_GAP_SHARE`,
        at most at its desired speed: there is no hurry) instead: chasing the road beyond the last vehicle it sees in
        a dense lane brought it to the zip merge far faster than the lane, overshooting every gap there."""
        style = self.style
        lowest, highest = MERGE_SPEED_SHARE * style.desired_speed_mps, style.desired_speed_mps + PASS_MARGIN_MPS
        full = self._soonest(gaps, seeker, gap_share, highest)
        if full is not None and full[0] <= zip_in_s:
            return full[1]
        if zip_in_s < np.inf:  # no gap for its time gaps before the zip merge: line up for it
            lined_up = self._soonest(gaps, seeker, URGENT_GAP_SHARE, style.desired_speed_mps)
            if lined_up is not None:
                return lined_up[1]
        return lowest if full is None else full[1]

    def _soonest(self, gaps: list[LaneGap], seeker: Seeker, gap_share: float,
                 highest_mps: float) -> tuple[float, float] | None:
        """The time [s] to the gap it reaches soonest and the set-point [m/s] that takes it there (`_reach`), down
        to `MERGE_SPEED_SHARE` of its desired speed, else at any speed; None: no gap in reach."""
        for floor_mps in (MERGE_SPEED_SHARE * self.style.desired_speed_mps, 0.0):
            reaches = [self._reach(gap, seeker, gap_share, floor_mps, highest_mps) for gap in gaps]
            found = [reach for reach in reaches if reach is not None]
            if found:
                time_s, speed_mps = min(found)
                return time_s, min(max(speed_mps, floor_mps), highest_mps)
        return None

    def _reach(self, gap: LaneGap, seeker: Seeker, gap_share: float, lowest_mps: float,
               highest_mps: float) -> tuple[float, float] | None:
        """The time [s] it takes to bring its front into the stretch of `gap` where a change keeps its gaps at the
        gap's speeds, and the set-point [m/s] that does it; None when the stretch is empty or out of reach. It closes
        in at the speed difference it can shed at `APPROACH_DECEL_MPS2` by the middle of the stretch, at least
        `PASS_MARGIN_MPS`, within `lowest_mps` and `highest_mps`. It starts to pass a vehicle only when it can draw
        `ZIP_REAR_GAP_M` ahead of it before SUMO's braking for its lane's end holds it back (`Seeker.can_gain`); once
        its front is past that vehicle's, it finishes the pass."""
        style = self.style
        first_m, last_m = gap.behind_m + seeker.length_m, gap.ahead_m
        if np.isfinite(gap.behind_speed_mps):
            first_m += style.min_gap_m + gap_share * style.rear_time_gap_s * gap.behind_speed_mps
        if np.isfinite(gap.ahead_speed_mps):
            last_m -= style.min_gap_m + gap_share * style.front_time_gap_s * gap.ahead_speed_mps
        if last_m < first_m:
            return None
        shed_mps = np.sqrt(2 * APPROACH_DECEL_MPS2 * abs(0.5 * (first_m + last_m)))  # by the stretch's middle
        if first_m > 0.0:  # move up past the vehicle behind the gap
            behind_mps = gap.behind_speed_mps
            target_mps = min(behind_mps + max(shed_mps, PASS_MARGIN_MPS), highest_mps, seeker.top_speed())
            if target_mps <= behind_mps or first_m > seeker.own.front_gap_m - style.min_gap_m:
                return None
            zip_need_m = gap.behind_m + seeker.length_m + min(ZIP_REAR_GAP_M, style.min_gap_m)
            if gap.behind_m > 0.0 and not seeker.can_gain(zip_need_m, behind_mps, target_mps):
                return None
            return _time_to_cover(first_m, seeker.speed_mps - behind_mps, target_mps - behind_mps), target_mps
        if last_m < 0.0:  # drop back behind the vehicle ahead of the gap
            ahead_mps = gap.ahead_speed_mps
            target_mps = max(ahead_mps - max(shed_mps, PASS_MARGIN_MPS), lowest_mps)
            if target_mps >= ahead_mps:
                return None
            return _time_to_cover(-last_m, ahead_mps - seeker.speed_mps, ahead_mps - target_mps), target_mps
        speeds = [speed for speed in (gap.ahead_speed_mps, gap.behind_speed_mps) if np.isfinite(speed)]
        return 0.0, (speeds[0] if speeds else style.desired_speed_mps)  # in it: keep pace with the lane

    def _toward(self, target_mps: float, set_point_mps: float) -> Action:
        """The speed action that moves the set-point `set_point_mps` toward `target_mps` [m/s]."""
        if set_point_mps < target_mps - self._half_step:
            return Action.ACCELERATE
        if set_point_mps > target_mps + self._half_step:
            return Action.DECELERATE
        return Action.KEEP

    def _lane_speed(self, gaps: LaneGaps, horizon_s: float) -> float:
        """Speed the ego could hold in a lane: its leader's, if that is within `horizon_s` at the desired speed."""
        desired = self.style.desired_speed_mps
        if gaps.front_gap_m < horizon_s * desired:
            return min(gaps.front_speed_mps, desired)
        return desired

    def _safe(self, gaps: LaneGaps, ego_speed_mps: float, gap_share: float = 1.0,
              braking_mps2: float = _COMFORT_DECEL_MPS2, route_demanded: bool = False) -> bool:
        """Nobody alongside and the gaps of the module's docstring, their time gaps scaled by `gap_share`, speed
        differences shed at `braking_mps2`; for a change its route demands (`route_demanded`) a slower follower's
        shorter braking distance counts against its time gap."""
        if gaps.alongside:
            return False
        needed_front, needed_rear = self._needed(gaps, ego_speed_mps, gap_share, braking_mps2, route_demanded)
        return gaps.front_gap_m >= needed_front and gaps.rear_gap_m >= needed_rear

    def _needed(self, gaps: LaneGaps, ego_speed_mps: float, gap_share: float,
                braking_mps2: float = _COMFORT_DECEL_MPS2, route_demanded: bool = False) -> tuple[float, float]:
        """The front and rear gaps [m] a change into the lane of `gaps` needs, speed differences shed at
        `braking_mps2`; `route_demanded`: a slower follower's shorter braking distance (at
        `SLOWER_FOLLOWER_BRAKING_MPS2`) counts against its time gap."""
        style = self.style
        excess = max(ego_speed_mps - gaps.front_speed_mps, 0.0) if np.isfinite(gaps.front_speed_mps) else 0.0
        needed_front = (style.min_gap_m + gap_share * style.front_time_gap_s * ego_speed_mps
                        + excess**2 / (2 * braking_mps2))
        closing = max(gaps.rear_speed_mps - ego_speed_mps, 0.0) if np.isfinite(gaps.rear_speed_mps) else 0.0
        rear_speed = gaps.rear_speed_mps if np.isfinite(gaps.rear_speed_mps) else 0.0
        # zip merging (time gaps scaled by URGENT_GAP_SHARE) in front of a follower no faster than itself
        rear_min_m = style.min_gap_m
        if gap_share == URGENT_GAP_SHARE and closing <= 0.0:
            rear_min_m = min(ZIP_REAR_GAP_M, style.min_gap_m)
        time_gap_m = gap_share * style.rear_time_gap_s * rear_speed
        if route_demanded and rear_speed < ego_speed_mps:
            time_gap_m = max(time_gap_m - (ego_speed_mps**2 - rear_speed**2) / (2 * SLOWER_FOLLOWER_BRAKING_MPS2), 0.0)
        needed_rear = rear_min_m + time_gap_m + closing**2 / (2 * braking_mps2)
        return needed_front, needed_rear


def _time_to_cover(distance_m: float, closing_mps: float, top_closing_mps: float) -> float:
    """Time [s] to gain `distance_m` [m] on a vehicle, from closing in on it at `closing_mps` (negative: falling
    back) toward `top_closing_mps` [m/s] at `SPEED_CHANGE_MPS2`."""
    if closing_mps >= top_closing_mps:
        return distance_m / closing_mps
    change_s = (top_closing_mps - closing_mps) / SPEED_CHANGE_MPS2
    change_m = 0.5 * (closing_mps + top_closing_mps) * change_s
    if change_m >= distance_m:
        return (np.sqrt(closing_mps**2 + 2 * SPEED_CHANGE_MPS2 * distance_m) - closing_mps) / SPEED_CHANGE_MPS2
    return change_s + (distance_m - change_m) / top_closing_mps


def route_demand_m(offset: int) -> float:
    """How far before a lane's end [m] the expert starts the `offset` lane changes the route demands."""
    return ROUTE_MARGIN_M + ROUTE_PER_LANE_M * abs(offset)


def _leads_on(route: RouteView | None, lane: int) -> bool:
    """A discretionary change into `lane` keeps the route: the lane leads on well past where the route would demand
    a change out of it again."""
    if route is None:
        return True
    offset = route.best_lane_offset(lane)
    return offset == 0 or route.lane_end(lane) > route_demand_m(offset) + 2 * ROUTE_PER_LANE_M


def make_expert(style_name: str, speed_step_mps: float, view_range_m: float = NO_VEHICLE) -> Expert:
    """The expert of a named style; KeyError-free: an unknown name is a ValueError naming the known styles."""
    if style_name not in STYLES:
        raise ValueError(f"unknown expert style {style_name!r}; known styles: {', '.join(sorted(STYLES))}")
    return Expert(STYLES[style_name], speed_step_mps, view_range_m)
