"""Digests of reference episodes: what `test_env_reference.py` compares the environment against.

The episodes (three of the 'normal' expert and one random driver on the small test scenario) are hashed column
by column (recorded steps, metrics, and the traffic views the drivers were shown), so any change in what the
environment computes (observations to the last bit, rewards, info, metrics) shows. Regenerate deliberately, only
when the simulated traffic is meant to change (a new SUMO, a new warm-state generation), with

    .venv/bin/python tests/sim/env_reference.py

which writes `env_reference.json` beside this file (it builds its warm states in a fresh temporary cache, as the
test session does).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from sumo_rail.config import Config
from sumo_rail.runners.rollout import Driver, EpisodeResult, ExpertDriver, RandomDriver, run_episode
from sumo_rail.sim.env import HighwayEnv, TrafficView

REFERENCE = Path(__file__).with_name("env_reference.json")
SMALL_SCENARIO: dict[str, Any] = {
    "scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3, "snapshot_interval_s": 10.0},
    "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
}
"""The overrides of tests/conftest.py's `small_config` (the test checks they agree)."""
EPISODES = (("expert-normal", 0), ("expert-normal", 3), ("expert-normal", 6), ("random", 9))
"""(driver, reset seed) of each reference episode."""
REFERENCE_METRICS = ("seed", "steps", "simulated_s", "distance_m", "average_speed_kmh", "overtakes", "overtaken",
                     "lane_changes", "longitudinal_reward", "lateral_reward", "collisions", "hard_braking", "teleports",
                     "invalid_actions", "action_keep", "action_accelerate", "action_decelerate", "action_lane_left",
                     "action_lane_right", "termination", "terminated", "truncated")
"""The metrics the reference holds; later measures (merges, missed exits, ...) are checked by their own tests."""


def digest(result: EpisodeResult) -> dict[str, str]:
    """SHA-256 of each recorded column (dtype, shape and bytes) and of the metrics row."""
    assert result.steps is not None
    hashes = {}
    for name, values in sorted(result.steps.items()):
        array = np.ascontiguousarray(values)
        hashes[name] = hashlib.sha256(f"{array.dtype.str}{array.shape}".encode() + array.tobytes()).hexdigest()
    reference_metrics = {key: value for key, value in result.metrics.items() if key in REFERENCE_METRICS}
    hashes["metrics"] = hashlib.sha256(json.dumps(reference_metrics, sort_keys=True, default=str).encode()).hexdigest()
    return hashes


def hashing(driver: Driver, sha: Any) -> Driver:
    """`driver`, feeding every traffic view it is shown (ego and neighbours, ids included) to `sha`."""
    def drive(observation: np.ndarray, traffic: TrafficView) -> int:
        sha.update(repr((traffic.ego, traffic.neighbours.ids, traffic.set_point_mps)).encode())
        for field in dataclasses.fields(traffic.neighbours)[1:]:
            array = getattr(traffic.neighbours, field.name)
            sha.update(array.dtype.str.encode() + np.ascontiguousarray(array).tobytes())
        return driver(observation, traffic)
    return drive


def episode_digests(config: Config) -> list[dict[str, Any]]:
    """Run the reference episodes on one environment; one entry per episode."""
    env = HighwayEnv(config)
    try:
        entries = []
        for driver_name, seed in EPISODES:
            spec = ExpertDriver("normal") if driver_name.startswith("expert") else RandomDriver()
            traffic = hashlib.sha256()
            result = run_episode(env, hashing(spec.create(config, seed), traffic), seed, record=True)
            entries.append({"driver": driver_name, "seed": seed, "decisions": result.metrics["steps"],
                            "lane_changes": result.metrics["lane_changes"],
                            "sha256": digest(result) | {"traffic": traffic.hexdigest()}})
        return entries
    finally:
        env.close()


def main() -> None:
    with tempfile.TemporaryDirectory() as cache:
        os.environ["SUMO_RAIL_CACHE"] = cache
        entries = episode_digests(Config.from_dict(SMALL_SCENARIO))
    REFERENCE.write_text(json.dumps({"episodes": entries}, indent=1) + "\n")
    print(f"wrote {REFERENCE} ({sum(e['decisions'] for e in entries)} decisions)", file=sys.stderr)


if __name__ == "__main__":
    main()
