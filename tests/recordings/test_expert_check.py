"""A written-and-read expert episode gives back the env's observations: the expert driven in the env, every vehicle
captured at each decision, written as FCD, imported, and the ego's observation computed from the scene."""

from __future__ import annotations

import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.expert_check import check_in_scratch

TOLERANCE = 0.002
"""Largest difference of a normalised observation entry from FCD's two decimals (docs/recordings.md)."""


@pytest.fixture(scope="module")
def config() -> Config:
    return Config.from_dict({"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3,
                                          "snapshot_interval_s": 10.0},
                             "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
                             "observation": {"lane_block": 1, "route_block": 1}})


def test_the_scene_gives_the_envs_observation_within_fcds_rounding(config):
    check = check_in_scratch(config, 1)
    assert check.decisions >= 30 and check.lane_changing > 0  # lane changes under way are compared too
    assert check.max_abs_difference < TOLERANCE
    assert "lane_change_in_progress" not in check.worst_entries and "lane_1" not in check.worst_entries


def test_with_six_decimals_it_is_the_envs_to_float32(config):
    check = check_in_scratch(config, 1, decimals=6)
    assert check.max_abs_difference < 1e-6, check.worst_entries
