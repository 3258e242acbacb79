import gymnasium
import libsumo
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import sumo_rail
from sumo_rail.runners.rollout import run_episode
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observation import observation_names
from sumo_rail.sim.simulation import EGO_ID, SimulationError

INFO_KEYS = {"speed_mps", "lane", "lane_changes", "overtakes", "collisions", "hard_braking", "teleports",
             "invalid_actions", "reward_longitudinal", "reward_lateral", "termination"}


@pytest.fixture
def env(small_config):
    environment = HighwayEnv(small_config)
    yield environment
    environment.close()


def rollout(env: HighwayEnv, seed: int, actions: list[int]):
    observations, rewards = [env.reset(seed=seed)[0]], []
    for action in actions:
        observation, reward, terminated, truncated, _ = env.step(action)
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            break
    return np.array(observations), np.array(rewards)


def test_registered_id_makes_the_env():
    env = gymnasium.make(sumo_rail.ENV_ID)
    try:
        observation, info = env.reset(seed=0)
        assert env.observation_space.contains(observation)
        assert INFO_KEYS <= set(info)
        assert len(observation) == len(observation_names(env.unwrapped.config))
    finally:
        env.close()


@pytest.mark.filterwarnings("error")  # a warning of the checker is a failure
def test_gymnasium_env_checker_passes(env):
    gymnasium_check_env(env, skip_render_check=True)


@pytest.mark.filterwarnings("error")  # a warning of the checker is a failure
def test_stable_baselines3_env_checker_passes(env):
    sb3_check_env(env, warn=True)


def test_same_seed_and_actions_reproduce_the_episode_bit_for_bit(env):
    actions = [Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP, Action.DECELERATE, Action.LANE_RIGHT] * 8
    first = rollout(env, 7, actions)
    rollout(env, 8, actions[::-1])
    again = rollout(env, 7, actions)
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1])


def test_traci_gives_the_libsumo_episode_bit_for_bit_and_can_run_beside_it(env, small_config):
    actions = [Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP, Action.DECELERATE, Action.LANE_RIGHT] * 4
    over_traci = HighwayEnv(small_config, transport="traci")
    try:
        traci_episode = rollout(over_traci, 7, actions)
        libsumo_episode = rollout(env, 7, actions)  # both open: only libsumo is limited to one per process
    finally:
        over_traci.close()
    assert len(traci_episode[1]) == len(actions)
    assert np.array_equal(traci_episode[0], libsumo_episode[0]) and np.array_equal(traci_episode[1], libsumo_episode[1])


def test_several_envs_run_in_one_process_as_a_gymnasium_sync_vector_env(small_config):
    actions = [Action.ACCELERATE, Action.LANE_LEFT, Action.KEEP, Action.DECELERATE, Action.LANE_RIGHT] * 4
    envs = gymnasium.vector.SyncVectorEnv([lambda: HighwayEnv(small_config)] * 3)  # libsumo, then traci
    try:
        with pytest.warns(UserWarning, match="runs over traci"):
            first, _ = envs.reset(seed=[7, 7, 8])
        steps = [envs.step(np.full(3, action)) for action in actions]
        assert [env.unwrapped.simulation.transport for env in envs.envs] == ["libsumo", "traci", "traci"]
    finally:
        envs.close()
    observations = np.stack([first] + [step[0] for step in steps])  # (decisions, envs, observation)
    assert np.array_equal(observations[:, 0], observations[:, 1])  # each env its own SUMO: same seed, same episode
    assert not np.array_equal(observations[:, 0], observations[:, 2])


def test_unknown_transport_is_a_clear_error(small_config):
    with pytest.raises(ValueError, match="transport must be one of auto, libsumo, traci"):
        HighwayEnv(small_config, transport="socket")


def test_different_seeds_give_different_traffic(env):
    keep = [Action.KEEP] * 10
    assert not np.array_equal(rollout(env, 1, keep)[0], rollout(env, 2, keep)[0])


def test_episode_on_keep_ends_at_the_end_of_the_road(env, small_config):
    env.reset(seed=3)
    terminated = truncated = False
    rewards = []
    while not (terminated or truncated):
        _, reward, terminated, truncated, info = env.step(Action.KEEP)
        rewards.append(reward)
    assert truncated and not terminated and info["termination"] == "end_of_road"
    assert info["position_m"] >= small_config.scenario.length_m - small_config.env.end_margin_m
    assert all(0.0 <= r <= 1.0 for r in rewards)  # no lane change, no collision: longitudinal only
    assert env.metrics.decisions == len(rewards) and env.metrics.action_counts[Action.KEEP] == len(rewards)


def test_time_limit_truncates(small_config):
    env = HighwayEnv(small_config.with_overrides({"env": {"max_episode_s": 2.0}}))
    try:
        env.reset(seed=0)
        results = [env.step(Action.KEEP) for _ in range(4)]
    finally:
        env.close()
    assert [r[3] for r in results] == [False, False, False, True]
    assert results[-1][4]["termination"] == "time_limit"


def test_lane_change_takes_time_costs_lateral_reward_and_counts(env):
    _, info = env.reset(seed=4)
    action = Action.LANE_LEFT if info["lane"] < 4 else Action.LANE_RIGHT
    lateral = []
    for _ in range(12):
        _, _, _, _, info = env.step(action)
        lateral.append(info["reward_lateral"])
        if info["lane_changes"]:
            break
        action = Action.KEEP if info["lane_change_in_progress"] else action
    for _ in range(6):
        _, _, _, _, info = env.step(Action.KEEP)
        lateral.append(info["reward_lateral"])
    assert info["lane_changes"] == 1
    # a 2 s manoeuvre spans at least 4 decisions of 0.5 s, each costing -0.5
    assert lateral.count(-0.5) >= 4 and set(lateral) <= {0.0, -0.5}


def test_impossible_lane_changes_do_nothing_and_are_counted(env):
    _, info = env.reset(seed=5)
    expected = 0
    for _ in range(12):
        expected += info["lane"] == 0
        _, _, _, _, info = env.step(Action.LANE_RIGHT)
    assert info["invalid_actions"] == expected >= 1


def _drive_into_a_blocker(lane: int, position_m: float) -> None:
    """The ego, without SUMO's safety checks, at 55 m/s towards a truck standing 60 m ahead in its lane."""
    libsumo.vehicle.setSpeedMode(EGO_ID, 0)
    libsumo.vehicle.setSpeed(EGO_ID, 55.0)
    libsumo.vehicle.add("blocker", "highway_route", typeID="truck", depart="now", departLane=str(lane),
                        departPos=str(position_m + 60.0), departSpeed="0")


def test_collision_terminates_with_penalty_and_the_info_of_any_step(env):
    _, info = env.reset(seed=6)
    _drive_into_a_blocker(info["lane"], info["position_m"])
    _, _, _, _, first = env.step(Action.KEEP)
    for _ in range(40):
        _, reward, terminated, truncated, info = env.step(Action.KEEP)
        if terminated or truncated:
            break
    assert terminated and not truncated
    assert reward == -10.0 and info["collisions"] == 1 and info["termination"] == "collision"
    assert set(info) == set(first) and info["lane_change_in_progress"] is False  # the last known state
    assert env.frame().shape[2] == 3  # the last decision's frame: the blocker, gone with the ego, drawn as it was


def test_a_collision_is_recorded_like_any_decision(env):
    added = []

    def crash(observation: np.ndarray, traffic) -> int:
        if not added:
            _drive_into_a_blocker(traffic.ego.lane, traffic.ego.lane_position_m)
            added.append(True)
        return Action.KEEP

    result = run_episode(env, crash, seed=6, record=True)
    assert result.metrics["collisions"] == 1 and result.metrics["termination"] == "collision"
    assert len(result.steps["action"]) == result.metrics["steps"] and result.steps["reward"][-1] == -10.0


def test_out_of_space_action_and_step_before_reset_are_errors(small_config):
    env = HighwayEnv(small_config)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)
    env.reset(seed=0)
    for invalid in (5, -1, 1.5, np.int64(7), "1"):
        with pytest.raises(ValueError, match="action must be"):
            env.step(invalid)
    for valid in (np.int64(1), np.array(2), Action.KEEP):
        env.step(valid)
    env.close()
    env.close()


def test_a_second_env_in_one_process_runs_over_traci_unless_libsumo_is_asked_for(env, small_config):
    env.reset(seed=0)
    strict = HighwayEnv(small_config, transport="libsumo")
    with pytest.raises(SimulationError, match=r"one simulation per process.*transport='traci'"):
        strict.reset(seed=0)
    second = HighwayEnv(small_config)
    try:
        with pytest.warns(UserWarning, match="runs over traci"):
            second.reset(seed=0)
        assert second.simulation.transport == "traci" and env.simulation.transport == "libsumo"
    finally:
        second.close()


def test_unknown_reset_options_are_refused_and_known_ones_reach_the_start_rule(env):
    """A Gymnasium user's misspelt option is an error (the core only warns, for PettingZoo's API test); the known
    ones are the start rule's."""
    with pytest.raises(ValueError, match=r"unknown reset options \['warmstate'\]; known: 'pool', 'warm_state'"):
        env.reset(seed=0, options={"warmstate": 1})
    with pytest.raises(ValueError, match="reset option 'warm_state'"):
        env.reset(seed=0, options={"warm_state": 99})


def test_metrics_before_the_first_reset_are_an_empty_episodes(small_config):
    from sumo_rail.sim.rewards import EpisodeMetrics

    env = HighwayEnv(small_config)
    assert env.metrics == EpisodeMetrics() and env.simulation is None


def test_a_reset_without_a_seed_draws_on_from_the_seeded_generator(env):
    """One generator, Gymnasium's: a reset without a seed (a vector env's autoreset) starts a new episode drawn on
    from the last seed's, not that episode again."""
    first = env.reset(seed=3)[0]
    second = env.reset()[0]
    assert not np.array_equal(first, second)
    assert np.array_equal(env.reset(seed=3)[0], first) and np.array_equal(env.reset()[0], second)
