"""The traffic around the ego as rule-based drivers and the lane-wise observation see it: the privileged view,
and the nearest vehicles ahead and behind in a lane."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sumo_rail.sim.records import quick_init
from sumo_rail.sim.vehicles import EgoState, Neighbours

NO_VEHICLE = np.inf
"""Gap and speed of a lane where nobody is seen."""
LANE_BLOCK_LANES = ("right", "own", "left")
LANE_BLOCK_FIELDS = ("front_gap", "front_relative_speed", "rear_gap", "rear_relative_speed")


@quick_init
@dataclass(frozen=True)
class TrafficView:
    """Privileged view of the traffic at the last decision, for rule-based drivers such as the expert."""

    ego: EgoState
    neighbours: Neighbours
    set_point_mps: float
    """The ego's current cruise set-point [m/s]."""
    lanes: int


@quick_init
@dataclass(frozen=True)
class LaneGaps:
    """The nearest vehicles ahead and behind the ego in one lane. Gaps are bumper to bumper [m]."""

    front_gap_m: float
    front_speed_mps: float
    rear_gap_m: float
    rear_speed_mps: float
    alongside: bool
    alongside_speed_mps: float = NO_VEHICLE
    """Speed of the vehicle alongside whose middle is nearest the ego's [m/s]; inf when nobody is alongside."""


def lane_gaps(traffic: TrafficView, lane: int) -> LaneGaps:
    """Gaps in `lane` around the ego; inf where nobody is seen (the context radius bounds what is seen)."""
    ego, others = traffic.ego, traffic.neighbours
    in_lane = others.lane == lane
    fronts = others.lane_position_m[in_lane]
    rears = fronts - others.length_m[in_lane]
    speeds = others.speed_mps[in_lane]
    ego_front, ego_rear = ego.lane_position_m, ego.lane_position_m - ego.length_m
    ahead, behind = rears > ego_front, fronts < ego_rear
    front_gap = front_speed = rear_gap = rear_speed = NO_VEHICLE
    if ahead.any():
        nearest = np.argmin(np.where(ahead, rears, np.inf))
        front_gap, front_speed = rears[nearest] - ego_front, speeds[nearest]
    if behind.any():
        nearest = np.argmax(np.where(behind, fronts, -np.inf))
        rear_gap, rear_speed = ego_rear - fronts[nearest], speeds[nearest]
    alongside = ~ahead & ~behind
    alongside_speed = NO_VEHICLE
    if alongside.any():
        offsets = np.abs((fronts + rears) - (ego_front + ego_rear))  # twice the distance between the middles
        alongside_speed = speeds[np.argmin(np.where(alongside, offsets, np.inf))]
    return LaneGaps(float(front_gap), float(front_speed), float(rear_gap), float(rear_speed), bool(alongside.any()),
                    float(alongside_speed))


def leader_gap_m(lanes: np.ndarray, fronts_m: np.ndarray, lengths_m: np.ndarray, row: int) -> float:
    """[m] from vehicle `row`'s front bumper to the rear of the nearest vehicle ahead in its lane (inf: none), given
    every vehicle's lane, front position along the road [m] and length [m] (a driven ego's or a recorded vehicle's:
    the seat evaluation's one gap to the leader)."""
    same = (lanes == lanes[row]) & (np.arange(len(lanes)) != row)
    rears = fronts_m[same] - lengths_m[same]
    ahead = rears[rears > fronts_m[row]] - fronts_m[row]
    return float(ahead.min()) if len(ahead) else NO_VEHICLE


def ego_leader_gap_m(traffic: TrafficView) -> float:
    """`leader_gap_m` of the ego among its neighbours [m] (inf: nobody seen ahead in its lane)."""
    ego, others = traffic.ego, traffic.neighbours
    return leader_gap_m(np.append(ego.lane, others.lane), np.append(ego.lane_position_m, others.lane_position_m),
                        np.append(ego.length_m, others.length_m), 0)


@quick_init
@dataclass(frozen=True)
class LaneGap:
    """The room between two consecutive vehicles of a lane, positions along the road from the ego's front [m]."""

    behind_m: float
    """Front of the vehicle behind the gap (-inf: nobody seen behind)."""
    behind_speed_mps: float
    """Its speed [m/s] (inf: nobody)."""
    ahead_m: float
    """Rear of the vehicle ahead of the gap (inf: nobody seen ahead)."""
    ahead_speed_mps: float
    """Its speed [m/s] (inf: nobody)."""


def lane_gap_list(traffic: TrafficView, lane: int) -> list[LaneGap]:
    """Every gap of `lane` between the vehicles seen there, from the rearmost (open behind) to the foremost (open
    ahead); one open gap when nobody is seen."""
    others, ego_front = traffic.neighbours, traffic.ego.lane_position_m
    in_lane = others.lane == lane
    order = np.argsort(others.lane_position_m[in_lane], kind="stable")
    fronts = (others.lane_position_m[in_lane][order] - ego_front).tolist()
    rears = (np.asarray(fronts) - others.length_m[in_lane][order]).tolist()
    speeds = others.speed_mps[in_lane][order].tolist()
    behind = [(-NO_VEHICLE, NO_VEHICLE), *zip(fronts, speeds, strict=True)]
    ahead = [*zip(rears, speeds, strict=True), (NO_VEHICLE, NO_VEHICLE)]
    return [LaneGap(float(b), float(b_speed), float(a), float(a_speed))
            for (b, b_speed), (a, a_speed) in zip(behind, ahead, strict=True)]


def within(traffic: TrafficView, range_m: float) -> TrafficView:
    """The view without the neighbours whose front is farther than `range_m` along the road from the ego's."""
    near = np.abs(traffic.neighbours.lane_position_m - traffic.ego.lane_position_m) <= range_m
    if near.all():
        return traffic
    others = traffic.neighbours
    kept = Neighbours(tuple(np.asarray(others.ids)[near]), others.front_xy[near], others.heading_rad[near],
                      others.speed_mps[near], others.lane_position_m[near], others.length_m[near],
                      others.width_m[near], others.lane[near])
    return dataclasses.replace(traffic, neighbours=kept)


def lane_block(traffic: TrafficView, range_m: float, v_max_mps: float) -> np.ndarray:
    """For the lanes right of, at and left of the ego: gap to the nearest vehicle ahead / r_max and its speed
    relative to the ego's / v_max, then the same behind, float32 (12 values, LANE_BLOCK_LANES x LANE_BLOCK_FIELDS).

    Gaps are capped at 1 (r_max, also where nobody is within range, with relative speed 0); a lane that does not
    exist reads as blocked (gaps 0, relative speeds 0). The nearest vehicles are `lane_gaps`' (the first of equals in
    the neighbours' order), found for the three lanes in one pass over the neighbours: a Python loop, which for the
    few vehicles around the ego is several times cheaper than numpy's calls (tests/sim/test_traffic.py compares it
    with `lane_gaps`, bit for bit)."""
    ego, others = traffic.ego, traffic.neighbours
    ego_front, ego_rear = ego.lane_position_m, ego.lane_position_m - ego.length_m
    lowest = ego.lane - 1
    nearest_rear = [NO_VEHICLE] * 3  # per lane (right, own, left): the rear of the nearest vehicle ahead [m] ...
    front_speed = [NO_VEHICLE] * 3
    nearest_front = [-NO_VEHICLE] * 3  # ... and the front of the nearest one behind [m]
    rear_speed = [NO_VEHICLE] * 3
    for front, length, lane, speed in zip(others.lane_position_m.tolist(), others.length_m.tolist(),
                                          others.lane.tolist(), others.speed_mps.tolist(), strict=True):
        row = lane - lowest
        if not 0 <= row < 3:
            continue
        rear = front - length
        if rear > ego_front:
            if rear < nearest_rear[row]:
                nearest_rear[row], front_speed[row] = rear, speed
        elif front < ego_rear and front > nearest_front[row]:
            nearest_front[row], rear_speed[row] = front, speed
    block: list[float] = []
    for row in range(3):
        if not 0 <= lowest + row < traffic.lanes:
            block += [0.0, 0.0, 0.0, 0.0]
            continue
        for gap, speed in ((nearest_rear[row] - ego_front, front_speed[row]),
                           (ego_rear - nearest_front[row], rear_speed[row])):
            seen = gap <= range_m
            block.append(min(max(gap, 0.0) / range_m, 1.0) if seen else 1.0)
            block.append(min(max((speed - ego.speed_mps) / v_max_mps, -1.0), 1.0) if seen else 0.0)
    return np.array(block, dtype=np.float32)
