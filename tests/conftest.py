"""Shared fixtures: a private cache per test session and a small, fast scenario."""

from __future__ import annotations

import os

import pytest

from sumo_rail.config import Config


@pytest.fixture(scope="session", autouse=True)
def private_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Build networks and warm states in a fresh cache, so tests never depend on an earlier run."""
    os.environ["SUMO_RAIL_CACHE"] = str(tmp_path_factory.mktemp("sumo-rail-cache"))


@pytest.fixture
def small_config() -> Config:
    """A shorter road and warm-up: episodes of ~60 decisions."""
    return Config.from_dict({
        "scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3, "snapshot_interval_s": 10.0},
        "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
    })
