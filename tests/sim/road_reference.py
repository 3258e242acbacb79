"""Digests of reference episodes on every road with a feature: what `test_road_reference.py` compares the environment
against, as `env_reference.py` does on the straight road.

On each road (the small test road with its feature, `test_scenarios.FEATURE`) in the recommended setting (LIDAR, lane
block and route block), an episode of the 'normal' expert and one of the random driver are hashed column by column
(recorded steps, metrics, and the traffic views the drivers were shown): any change in what the environment computes
where the route frame, the route view and the lane and route blocks matter shows. Regenerate deliberately, only when
the simulated traffic is meant to change (a new SUMO, a new warm-state generation), with

    .venv/bin/python tests/sim/road_reference.py

which writes `road_reference.json` beside this file (it builds its warm states in a fresh temporary cache, as the
test session does).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

from env_reference import SMALL_SCENARIO, digest, hashing

from sumo_rail.config import Config
from sumo_rail.runners.rollout import ExpertDriver, RandomDriver, run_episode
from sumo_rail.sim.env import HighwayEnv

REFERENCE = Path(__file__).with_name("road_reference.json")
ROADS = ("merge", "merge_from_ramp", "lane_drop", "exit")
"""Every generated road with a feature."""
FEATURE = {"feature_at_m": 750.0, "feature_length_m": 250.0}
"""The small test road's feature (`test_scenarios.FEATURE`, which the test checks it agrees with)."""
EPISODES = (("expert-normal", 0), ("random", 1))
"""(driver, reset seed) of each reference episode of a road."""


def road_config(kind: str) -> Config:
    """The small test road of `kind` in the recommended setting."""
    return Config.from_dict(SMALL_SCENARIO).with_overrides({
        "scenario": {"kind": kind, **FEATURE}, "observation": {"lane_block": 1, "route_block": 1}})


def road_digests() -> list[dict[str, Any]]:
    """Run the reference episodes of every road; one entry per episode."""
    entries = []
    for kind in ROADS:
        config = road_config(kind)
        env = HighwayEnv(config)
        try:
            for driver_name, seed in EPISODES:
                spec = ExpertDriver("normal") if driver_name.startswith("expert") else RandomDriver()
                traffic = hashlib.sha256()
                result = run_episode(env, hashing(spec.create(config, seed), traffic), seed, record=True)
                entries.append({"road": kind, "driver": driver_name, "seed": seed,
                                "decisions": result.metrics["steps"], "lane_changes": result.metrics["lane_changes"],
                                "sha256": digest(result) | {"traffic": traffic.hexdigest()}})
        finally:
            env.close()
    return entries


def main() -> None:
    with tempfile.TemporaryDirectory() as cache:
        os.environ["SUMO_RAIL_CACHE"] = cache
        entries = road_digests()
    REFERENCE.write_text(json.dumps({"episodes": entries}, indent=1) + "\n")
    print(f"wrote {REFERENCE} ({sum(e['decisions'] for e in entries)} decisions)", file=sys.stderr)


if __name__ == "__main__":
    main()
