"""Pure reward terms, the overtake definition and the per-episode metrics accumulator."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

AHEAD, ALONGSIDE, BEHIND = 1, 0, -1


def longitudinal_reward(speed_mps: float, v_min_mps: float, v_max_mps: float) -> float:
    """(v - v_min) / (v_max - v_min), clipped to [0, 1]."""
    return min(max((speed_mps - v_min_mps) / (v_max_mps - v_min_mps), 0.0), 1.0)


def lateral_reward(lane_change_in_progress: bool, per_decision: float) -> float:
    """`per_decision` (negative) for a decision during which a lane change was in progress, else 0."""
    return per_decision if lane_change_in_progress else 0.0


def relations(ego_front_m: float, ego_length_m: float, fronts_m: np.ndarray, lengths_m: np.ndarray) -> list[int]:
    """Longitudinal relation of each vehicle to the ego along the road.

    AHEAD: its rear is beyond the ego's front; BEHIND: its front is short of the ego's rear; else ALONGSIDE.
    (A Python loop: for the few vehicles around the ego it is several times cheaper than numpy's calls.)
    """
    ego_rear = ego_front_m - ego_length_m
    return [AHEAD if front - length > ego_front_m else BEHIND if front < ego_rear else ALONGSIDE
            for front, length in zip(fronts_m.tolist(), lengths_m.tolist(), strict=True)]


class OvertakeCounter:
    """Counts overtakes: a vehicle (any lane) last seen strictly AHEAD of the ego is now strictly BEHIND it.

    Passing alongside in between is allowed, each pass counts once, and the reverse (the ego being
    overtaken) is counted separately. Vehicles are followed by ID while they are observed.
    """

    def __init__(self) -> None:
        self._last_strict: dict[str, int] = {}
        self.overtakes = 0
        self.overtaken = 0

    def update(self, ids: tuple[str, ...], relation: Sequence[int]) -> int:
        """Record this decision's relations (see `relations`); returns the number of new overtakes by the ego."""
        new = 0
        last = self._last_strict
        for vehicle_id, now in zip(ids, relation, strict=True):
            if now == ALONGSIDE:
                continue
            before = last.get(vehicle_id)
            if before == now:
                continue
            if before == AHEAD and now == BEHIND:
                new += 1
            elif before == BEHIND and now == AHEAD:
                self.overtaken += 1
            last[vehicle_id] = now
        self.overtakes += new
        return new


@dataclass
class EpisodeMetrics:
    """Running totals of one episode (what `info` reports and evaluation tables store)."""

    decisions: int = 0
    simulated_s: float = 0.0
    distance_m: float = 0.0
    speed_sum_mps: float = 0.0
    overtakes: int = 0
    overtaken: int = 0
    lane_changes: int = 0
    longitudinal_reward: float = 0.0
    lateral_reward: float = 0.0
    collisions: int = 0
    hard_braking: int = 0
    teleports: int = 0
    invalid_actions: int = 0
    action_counts: list[int] = field(default_factory=lambda: [0] * 5)
    merges: int = 0
    """Moves out of a lane that ends along the route into one that leads farther (`sumo_rail.sim.route_progress`)."""
    merge_time_s: float = 0.0
    """Their time, summed [s]."""
    missed_exits: int = 0
    """1 when the episode ended standing at the end of a lane that leads off the route (its exit missed)."""
    lane_end_stops: int = 0
    """1 when the episode ended standing at the end of a lane that ends."""

    @property
    def average_speed_mps(self) -> float:
        """Mean ego speed over decisions [m/s]."""
        return self.speed_sum_mps / self.decisions if self.decisions else 0.0
