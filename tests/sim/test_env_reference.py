"""The environment computes exactly what it did when `env_reference.json` was recorded (see env_reference.py)."""

from __future__ import annotations

import json

from env_reference import EPISODES, REFERENCE, SMALL_SCENARIO, episode_digests

from sumo_rail.config import Config


def test_reference_scenario_is_the_small_test_scenario(small_config):
    assert Config.from_dict(SMALL_SCENARIO) == small_config


def test_expert_and_random_episodes_are_byte_identical_to_the_reference(small_config):
    expected = json.loads(REFERENCE.read_text())["episodes"]
    assert [(e["driver"], e["seed"]) for e in expected] == list(EPISODES)
    actual = episode_digests(small_config)
    assert any(e["lane_changes"] for e in expected)  # the reference covers lane changes
    for want, got in zip(expected, actual, strict=True):
        assert got["decisions"] == want["decisions"], (want["driver"], want["seed"])
        differing = sorted(name for name in want["sha256"] if got["sha256"].get(name) != want["sha256"][name])
        assert differing == [], (want["driver"], want["seed"])
