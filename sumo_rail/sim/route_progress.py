"""How an ego gets on along its route: merges out of lanes that end, and the failures that end an episode (a stop
at the end of a lane that does not lead along the route); and the route block of the observation.

A merge is a move out of a lane that ends along the route into one that leads farther. Its time runs from the first
decision at which the ego's lane ends within `observation.route_range_m` with a lane leading farther beside it (the
ego could start the merge) to the first decision in a lane that leads farther. A failure is the ego standing (speed
below `STOP_SPEED_MPS`) within `STOP_ZONE_M` of its lane's end: a missed exit when the road goes on elsewhere there
(a diverge: the lane leads off the ego's route), else a stop at a lane end.
"""

from __future__ import annotations

import math

import numpy as np

from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.vehicles import EgoState

STOP_SPEED_MPS = 0.5
"""Below this speed the ego stands [m/s]."""
STOP_ZONE_M = 30.0
"""Standing this close to the end of its lane is a failure [m]."""
ROUTE_BLOCK_FIELDS = ("route_lane_end", "route_lane_offset", "route_merge_ahead", "route_diverge_ahead")


class RouteProgress:
    """Follows one ego's merges over an episode; `range_m` is how far ahead a lane's end counts [m]."""

    def __init__(self, range_m: float) -> None:
        self.range_m = range_m
        self._merge_began_s: float | None = None

    def update(self, ego: EgoState, time_s: float, metrics: EpisodeMetrics) -> None:
        """Count a merge completed at this decision; start a merge's clock where one can begin."""
        route = ego.route
        if route is None:
            return
        ending = route.lane_end(ego.lane) < max(route.lane_end_m)
        if self._merge_began_s is not None and not ending and not ego.changing_lane:
            metrics.merges += 1
            metrics.merge_time_s += time_s - self._merge_began_s
            self._merge_began_s = None
        elif self._merge_began_s is None and ending and route.lane_end(ego.lane) <= self.range_m:
            beside = route.best_lane_offset(ego.lane)
            if abs(beside) == 1 or ego.changing_lane:
                self._merge_began_s = time_s

    @staticmethod
    def failure(ego: EgoState) -> str:
        """"missed_exit" or "lane_end" when the ego stands at the end of a lane that does not lead along its route,
        else ""."""
        route = ego.route
        if route is None or ego.speed_mps >= STOP_SPEED_MPS:
            return ""
        lane_end_m = route.lane_end(ego.lane)
        if not (lane_end_m <= STOP_ZONE_M and lane_end_m < max(route.lane_end_m)):
            return ""
        return "missed_exit" if abs(route.diverge_ahead_m - lane_end_m) <= STOP_ZONE_M else "lane_end"


def zip_merge_change(route: RouteView, lane: int, target_lane: int, zip_merge_m: float) -> bool:
    """A change from `lane` to `target_lane` is a zip merge: toward the nearest lane that leads farthest, within
    `zip_merge_m` [m] of the end of a lane that does not."""
    offset = route.best_lane_offset(lane)
    return offset != 0 and (target_lane - lane) * offset > 0 and route.lane_end(lane) <= zip_merge_m


def route_values(ego: EgoState, range_m: float, lanes: int) -> tuple[float, float, float, float]:
    """The route block's values (`ROUTE_BLOCK_FIELDS`, in [-1, 1]): how far the ego's lane leads along its route /
    `range_m`, capped at 1; lanes to move to the nearest lane that leads farthest (positive = left) / (lanes - 1),
    clipped to [-1, 1]; distances to the next merge and the next diverge / `range_m`, capped at 1 (1: none within
    range)."""
    route = ego.route
    if route is None:
        return 1.0, 0.0, 1.0, 1.0
    offset = route.best_lane_offset(ego.lane) / max(lanes - 1, 1)
    return (_share(route.lane_end(ego.lane), range_m), min(max(offset, -1.0), 1.0),
            _share(route.merge_ahead_m, range_m), _share(route.diverge_ahead_m, range_m))


def route_block(ego: EgoState, range_m: float, lanes: int) -> np.ndarray:
    """The route block of the observation: `route_values` as float32."""
    return np.array(route_values(ego, range_m, lanes), dtype=np.float32)


def _share(distance_m: float, range_m: float) -> float:
    return 1.0 if not math.isfinite(distance_m) else min(max(distance_m, 0.0) / range_m, 1.0)
