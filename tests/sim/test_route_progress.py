"""sim/route_progress.py: the merge clock on a scripted merge, known values."""

import pytest

from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.route_progress import RouteProgress
from sumo_rail.sim.vehicles import EgoState


def ego_in(lane: int, lane_end_m: tuple[float, ...], lateral_offset_m: float = 0.0) -> EgoState:
    route = RouteView(0, len(lane_end_m) - 1, lane_end_m, 100.0, float("inf"), 2000.0)
    return EgoState(front_x=0.0, front_y=0.0, heading_rad=0.0, speed_mps=25.0, lane=lane, lane_position_m=0.0,
                    lateral_offset_m=lateral_offset_m, length_m=4.5, width_m=1.8, route=route)


def test_a_scripted_merge_takes_the_time_from_its_first_chance_to_the_lane_that_leads_on():
    """Lane 0 ends: out of range at t = 0 (600 m, range 500 m), in range from t = 2 s (the clock starts), the change
    under way at t = 4.5 s (between lanes, still lane 0), in lane 1 at t = 5.5 s: one merge of 3.5 s."""
    progress, metrics = RouteProgress(range_m=500.0), EpisodeMetrics()
    progress.update(ego_in(0, (600.0, float("inf"))), 0.0, metrics)
    progress.update(ego_in(0, (450.0, float("inf"))), 2.0, metrics)
    progress.update(ego_in(0, (300.0, float("inf")), lateral_offset_m=0.8), 4.5, metrics)
    assert metrics.merges == 0
    progress.update(ego_in(1, (float("inf"), float("inf"))), 5.5, metrics)
    assert metrics.merges == 1 and metrics.merge_time_s == pytest.approx(3.5)
    progress.update(ego_in(1, (float("inf"), float("inf"))), 7.0, metrics)
    assert metrics.merges == 1 and metrics.merge_time_s == pytest.approx(3.5)  # counted once
