"""The acceleration interface (`[actions] interface = "acceleration"`): its settings, its commands, and the ego in
SUMO following a commanded acceleration, above the road's limit, without driving into its leader."""

from __future__ import annotations

import numpy as np
import pytest
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env

from sumo_rail.action_config import ActionConfig
from sumo_rail.bounds import ConfigError
from sumo_rail.config import Config
from sumo_rail.setting_tables import field_docs
from sumo_rail.sim.actions import (
    Action,
    Lateral,
    acceleration_action,
    acceleration_command,
    action_space_of,
    paper_equivalent,
    split_acceleration_action,
)
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import control_slot, observation_names
from sumo_rail.sim.parallel_env import ParallelHighwayEnv

ACCELERATION = {"actions": {"interface": "acceleration"}}


def test_default_bins_cover_the_recordings_range_in_quarter_steps():
    actions = ActionConfig(interface="acceleration")
    assert actions.acceleration_bins == 37
    assert actions.acceleration_mps2(0) == -6.0 and actions.acceleration_mps2(36) == 3.0
    assert actions.acceleration_mps2(actions.nearest_bin(0.0)) == 0.0
    assert actions.nearest_bin(1.13) == actions.nearest_bin(1.25) == 29
    assert actions.nearest_bin(-40.0) == 0 and actions.nearest_bin(40.0) == 36
    assert action_space_of(actions) == spaces.Discrete(111)
    assert action_space_of(ActionConfig()) == spaces.Discrete(5)
    said = " ".join(field_docs(ActionConfig)["interface"].split())  # the setting's help names the env's space
    assert "the action space Discrete(3 x bins), 111 actions at the default bins" in said


def test_an_action_is_a_bin_and_a_lane_decision_in_one_integer():
    actions = ActionConfig(interface="acceleration")
    pairs = [(acceleration_bin, lateral) for lateral in Lateral for acceleration_bin in range(37)]
    assert [acceleration_action(*pair, actions) for pair in pairs] == list(range(111))
    assert [split_acceleration_action(action, actions) for action in range(111)] == pairs
    assert acceleration_action(24, Lateral.KEEP, actions) == 24  # below the bin count: keep the lane


@pytest.mark.parametrize(("settings", "message"), [
    ({"interface": "throttle"}, "unknown actions.interface 'throttle'"),
    ({"acceleration_bin_mps2": 0.24}, "into whole bins"),
    ({"acceleration_bin_mps2": 0.5}, "actions.acceleration_bin_mps2 must be between 0.05 and 0.25"),
    ({"acceleration_min_mps2": 0.0}, "actions.acceleration_min_mps2 must be at least -9 and below 0"),
])
def test_impossible_interface_settings_are_one_sentence(settings, message):
    with pytest.raises(ConfigError, match=message):
        Config.from_dict({"actions": settings})


def test_a_lane_change_of_an_acceleration_action_is_requested_like_the_papers(free_road):
    env = HighwayEnv(config=free_road)
    try:
        _, info = env.reset(seed=3)
        lane = info["lane"]
        for _ in range(6):
            _, _, _, _, info = env.step(acceleration_action(24, Lateral.LEFT if lane == 0 else Lateral.RIGHT,
                                                            free_road.actions))
            if info["lane"] != lane:
                break
        assert abs(info["lane"] - lane) == 1 and env.metrics.lane_changes == 1
    finally:
        env.close()


def test_an_acceleration_action_commands_its_bin_and_lane():
    actions = ActionConfig(interface="acceleration")
    assert acceleration_command(36, Lateral.KEEP, actions, 2, 5).acceleration_mps2 == 3.0
    left = acceleration_command(0, Lateral.LEFT, actions, 2, 5)
    assert (left.acceleration_mps2, left.target_lane, left.invalid) == (-6.0, 3, False)
    assert acceleration_command(24, Lateral.RIGHT, actions, 2, 5).target_lane == 1
    off = acceleration_command(24, Lateral.RIGHT, actions, 0, 5)
    assert off.invalid and off.target_lane is None and off.acceleration_mps2 == 0.0
    assert acceleration_command(24, Lateral.LEFT, actions, 4, 5).invalid


@pytest.mark.parametrize(("acceleration", "lateral", "expected"), [
    (0.0, Lateral.KEEP, Action.KEEP), (0.25, Lateral.KEEP, Action.ACCELERATE), (-0.25, Lateral.KEEP, Action.DECELERATE),
    (2.0, Lateral.LEFT, Action.LANE_LEFT), (-1.0, Lateral.RIGHT, Action.LANE_RIGHT),
])
def test_each_acceleration_action_counts_as_one_of_the_papers(acceleration, lateral, expected):
    assert paper_equivalent(acceleration, lateral) is expected


@pytest.fixture
def free_road(small_config):
    """The small road with so little traffic that the ego rarely has a leader near."""
    return small_config.with_overrides({**ACCELERATION, "scenario": {"flow_veh_per_h": 200.0}})


def test_the_env_passes_gymnasiums_checker_and_names_the_control_entry(free_road):
    env = HighwayEnv(config=free_road)
    try:
        check_env(env, skip_render_check=True)
        assert env.action_space == spaces.Discrete(111)
        assert observation_names(free_road)[control_slot(free_road)] == "last_acceleration"
    finally:
        env.close()


def test_the_ego_follows_a_commanded_acceleration_exactly_and_sees_it(free_road):
    actions = free_road.actions
    env = HighwayEnv(config=free_road)
    try:
        _, info = env.reset(seed=3)
        speed = info["speed_mps"]
        for acceleration in (-2.0, -2.0, 1.25, 0.0):
            observation, _, _, _, info = env.step(acceleration_action(actions.nearest_bin(acceleration), Lateral.KEEP,
                                                                      actions))
            assert info["speed_mps"] == pytest.approx(speed + acceleration * 0.5, abs=1e-6)
            assert observation[control_slot(free_road)] == pytest.approx((acceleration + 6.0) / 9.0)
            assert info["set_point_mps"] == info["speed_mps"]  # what an acceleration of 0 holds
            speed = info["speed_mps"]
    finally:
        env.close()


def test_the_ego_speeds_past_the_roads_limit_on_a_free_road(free_road):
    env = HighwayEnv(config=free_road)
    try:
        env.reset(seed=3)
        speeds = [env.step(36)[4]["speed_mps"] for _ in range(24)]
        assert max(speeds) > free_road.scenario.speed_limit_mps + 5.0
    finally:
        env.close()


def test_full_throttle_never_drives_the_egos_into_their_leaders(small_config):
    """Eight egos in dense traffic at the interface's highest acceleration all episode: SUMO's safe speed brakes
    them behind every leader (with the safe speed off, speed mode 24, they collide)."""
    config = small_config.with_overrides({**ACCELERATION, "scenario": {"flow_veh_per_h": 6000.0}})
    env = ParallelHighwayEnv(egos=8, config=config)
    try:
        env.reset(seed=5)
        collided, slowed = 0, 0
        while env.agents:
            _, _, terminations, _, infos = env.step({agent: 36 for agent in env.agents})
            collided += sum(terminations.values())
            slowed += sum(info["speed_mps"] < 25.0 for info in infos.values())
        assert collided == 0
        assert slowed > 0  # the traffic held them back: the safe speed was at work
    finally:
        env.close()


@pytest.mark.parametrize("action", [111, -1, 1.5, np.array([3, 0]), np.nan, "3"])
def test_actions_outside_the_interface_are_one_sentence(free_road, action):
    env = HighwayEnv(config=free_road)
    try:
        env.reset(seed=3)
        with pytest.raises(ValueError, match=r"action must be an integer in \[0, 111\)"):
            env.step(action)
    finally:
        env.close()
