"""Starts on a road whose flow is more than its start lets in: traffic queues to enter, and SUMO, which tries no
further vehicle in a lane once one failed there in a step, would never get to an ego behind that queue."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv

QUEUED_FLOW = 10000.0
"""veh/h: after a 600 s warm-up some 200 vehicles wait to enter the small road (no other test uses this flow)."""


@pytest.fixture
def queued_config(small_config) -> Config:
    return small_config.with_overrides({"scenario": {"flow_veh_per_h": QUEUED_FLOW, "warmup_s": 600.0}})


def test_an_ego_behind_a_queue_of_entering_traffic_starts_and_k1_on_the_shared_road_is_the_same(queued_config):
    single, shared = HighwayEnv(queued_config), ParallelHighwayEnv(1, queued_config)
    try:
        for seed in (0, 1):
            observation, info = single.reset(seed=seed)
            observations, infos = shared.reset(seed=seed)
            queued = len(single.simulation._api.simulation.getPendingVehicles())
            assert queued >= queued_config.scenario.lanes  # the situation: traffic queues to enter the road
            assert np.array_equal(observations["ego_0"], observation) and infos["ego_0"] == info
            for _ in range(3):
                step = single.step(Action.KEEP)
                steps = shared.step({"ego_0": Action.KEEP})
                assert np.array_equal(steps[0]["ego_0"], step[0]) and steps[1]["ego_0"] == step[1]
    finally:
        single.close()
        shared.close()
