"""The environment computes exactly what it did when `road_reference.json` was recorded, on every road with a feature
(see road_reference.py)."""

from __future__ import annotations

import json

from road_reference import EPISODES, FEATURE, REFERENCE, ROADS, road_digests
from test_scenarios import FEATURE as SCENARIO_FEATURE


def test_reference_roads_are_the_scenario_tests_roads():
    assert FEATURE == SCENARIO_FEATURE


def test_expert_and_random_episodes_on_every_road_are_byte_identical_to_the_reference():
    expected = json.loads(REFERENCE.read_text())["episodes"]
    assert [(e["road"], e["driver"], e["seed"]) for e in expected] == [(kind, *episode) for kind in ROADS
                                                                        for episode in EPISODES]
    assert any(e["lane_changes"] for e in expected)  # the reference covers lane changes
    for want, got in zip(expected, road_digests(), strict=True):
        assert got["decisions"] == want["decisions"], (want["road"], want["driver"], want["seed"])
        differing = sorted(name for name in want["sha256"] if got["sha256"].get(name) != want["sha256"][name])
        assert differing == [], (want["road"], want["driver"], want["seed"])
