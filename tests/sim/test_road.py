"""`RouteView` on made-up views (the route frame built from SUMO is tested in test_scenarios.py)."""

from __future__ import annotations

import numpy as np

from sumo_rail.sim.road import RouteView


def test_the_best_lane_offset_is_the_nearest_lane_that_leads_farthest_the_right_one_of_two_as_near():
    rng = np.random.default_rng(0)
    choices = [np.inf, 0.0, 50.0, 100.0]
    for _ in range(5000):
        lanes, lowest = int(rng.integers(1, 7)), int(rng.integers(-1, 2))
        ends = tuple(float(rng.choice(choices)) if rng.random() < 0.7 else float(rng.uniform(-10, 500))
                     for _ in range(lanes))
        view = RouteView(lowest, lowest + lanes - 1, ends, np.inf, np.inf, np.inf)
        lane = int(rng.integers(lowest - 2, lowest + lanes + 2))
        farthest = max(ends)
        best = [lowest + index - lane for index, end in enumerate(ends) if end >= farthest]
        expected = 0 if view.lane_end(lane) >= farthest else min(best, key=lambda offset: (abs(offset), offset))
        assert view.best_lane_offset(lane) == expected, (view, lane)
