"""Several egos per SUMO for Stable-Baselines3: respawning roads, their VecEnv, and `ppo`/`gail` with --egos."""

from __future__ import annotations

import json
import os
import signal
import threading

import numpy as np
import pandas as pd
import pytest
from gymnasium.utils import seeding
from test_cli import SMALL, SMALL_CONFIG, invoke

from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.sb3.driving_envs import driving_processes
from sumo_rail.learning.sb3.envs import close_envs
from sumo_rail.learning.sb3.shared_road import RespawningRoad, env_seeds
from sumo_rail.runners.rollout import drive_egos
from sumo_rail.sim import parallel_env
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.respawning import RespawningEgos


def drive(road: RespawningRoad, steps: int, seed: int):
    """`steps` decisions of seeded random actions; the reset's observations, then each step's batch."""
    rng = np.random.default_rng(seed)
    batches = [road.reset()]
    for _ in range(steps):
        batches.append(road.step(rng.integers(0, 5, size=road.env.max_num_agents).tolist()))
    return batches


@pytest.fixture(scope="module")
def roads():
    """The same three-ego road driven twice for 400 decisions."""
    runs = []
    for _ in range(2):
        road = RespawningRoad(SMALL_CONFIG, egos=3, seed=5)
        try:
            runs.append(drive(road, 400, seed=0))
        finally:
            road.close()
    return runs


def test_every_ego_always_drives_and_an_ended_episode_is_reported_as_sb3_does(roads):
    ended = 0
    for observations, rewards, dones, infos in roads[0][1:]:
        assert observations.shape == (3, 56) and rewards.shape == dones.shape == (3,)
        for ego in np.flatnonzero(dones):
            ended += 1
            info = infos[ego]
            truncated = info["termination"] in ("end_of_road", "time_limit")
            assert info["TimeLimit.truncated"] == truncated and info["termination"] in ("collision", "end_of_road")
            assert info["terminal_observation"].shape == (56,)
            assert not np.array_equal(info["terminal_observation"], observations[ego])  # a new episode's first
        for ego in np.flatnonzero(~dones):
            assert "terminal_observation" not in infos[ego]
    assert ended >= 3  # 400 decisions on the small road: each ego ended at least once and drove on


def test_the_same_seed_gives_the_same_rollouts_bit_for_bit(roads):
    for (a, b) in zip(roads[0][1:], roads[1][1:], strict=True):
        for left, right in zip(a[:3], b[:3], strict=True):
            assert np.array_equal(left, right)
        assert [info["position_m"] for info in a[3]] == [info["position_m"] for info in b[3]]


def test_one_ego_is_bit_for_bit_what_sb3_gave_for_the_single_ego_env():
    """One ego a road (what `gail`/`ppo` run by default) against what they ran before issue 34: SB3's SubprocVecEnv
    of a `HighwayEnv` whose generator was seeded, which steps, and on an episode's end keeps the last observation
    and resets the env (its worker's loop, written out)."""
    actions = np.random.default_rng(4).integers(0, 5, size=250).tolist()
    env = HighwayEnv(SMALL_CONFIG, transport="libsumo")
    try:
        env.np_random, _ = seeding.np_random(11)
        expected = [np.stack([env.reset()[0]])]
        for action in actions:
            observation, reward, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                info = {**info, "TimeLimit.truncated": truncated and not terminated,
                        "terminal_observation": observation}
                observation, _ = env.reset()
            expected.append((np.stack([observation]), np.array([reward]), np.array([terminated or truncated]), [info]))
    finally:
        env.close()
    road = RespawningRoad(SMALL_CONFIG, egos=1, seed=11)
    try:
        actual = [road.reset()] + [road.step([action]) for action in actions]
    finally:
        road.close()
    assert sum(bool(batch[2][0]) for batch in expected[1:]) >= 2  # two episodes ended: the road reset twice
    assert np.array_equal(actual[0], expected[0])
    for (*got, got_infos), (*want, want_infos) in zip(actual[1:], expected[1:], strict=True):
        assert all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(got, want, strict=True))
        terminal = want_infos[0].pop("terminal_observation", None)
        assert terminal is None or np.array_equal(got_infos[0].pop("terminal_observation"), terminal)
        assert got_infos == want_infos


def test_the_vec_env_is_its_processes_roads_side_by_side_and_a_ctrl_c_while_they_start_spares_them(tmp_path):
    rng = np.random.default_rng(1)
    actions = rng.integers(0, 5, size=(60, 4))
    venv = driving_processes(SMALL_CONFIG, processes=2, egos=2, seed=3, error_dir=tmp_path)
    try:
        for process in venv.processes:  # Ctrl-C reaches the process group while they import: the parent decides
            os.kill(process.pid, signal.SIGINT)
        vectorised = [venv.reset()] + [venv.step(step)[0] for step in actions]
    finally:
        venv.close()
    for process, road_seed in enumerate(env_seeds(3, 2)):
        road = RespawningRoad(SMALL_CONFIG, egos=2, seed=road_seed)
        try:
            alone = [road.reset()] + [road.step(step[2 * process:2 * process + 2].tolist())[0] for step in actions]
        finally:
            road.close()
        for together, by_itself in zip(vectorised, alone, strict=True):
            assert np.array_equal(together[2 * process:2 * process + 2], by_itself)


@pytest.mark.parametrize("command", ["ppo", "gail"])
def test_ppo_and_gail_with_several_egos_a_process_are_reproducible(tmp_path, command):
    extra = (["--demos", str(tmp_path / "demos.parquet"), "--set", "bc.epochs=1"] if command == "gail"
             else ["--set", "ppo.batch_size=32"])
    if command == "gail":
        result = invoke("record-expert", *SMALL, "--episodes", "2", "--out", str(tmp_path / "demos.parquet"))
        assert result.exit_code == 0, result.output
    common = (command, *SMALL, "--timesteps", "256", *(part for word in ("envs=1", "egos=2", "n_steps=64",
                                                                        "critic_warmup=0")
                                                        for part in ("--set", f"{command}.{word}")), *extra)
    for name in ("a", "b"):
        result = invoke(*common, "--out", str(tmp_path / name))
        assert result.exit_code == 0, result.output
    first, _ = load_policy(tmp_path / "a" / "policy_latest.npz")
    second, _ = load_policy(tmp_path / "b" / "policy_latest.npz")
    assert np.array_equal(first.parameters, second.parameters)
    log = pd.read_parquet(tmp_path / "a" / "log.parquet")
    assert log["env_steps"].tolist() == [128, 128]  # 64 decisions of each of the two egos per update
    assert json.loads((tmp_path / "a" / "run.json").read_text())["settings"]["egos"] == 2


def test_too_many_egos_for_the_road_is_a_usage_error(tmp_path):
    result = invoke("ppo", *SMALL, "--set", "ppo.egos=40", "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and "40 egos need start slots" in result.output
    assert not (tmp_path / "run").exists()


def jam_next_respawn(monkeypatch, env) -> None:
    """Make the next respawn of `env` find no place (every draw of it refused), then let places be found again."""
    place, refusals = env.simulation.place_ego, [2 * parallel_env.RESPAWN_DRAWS]

    def jammed(*args):
        refusals[0] -= 1
        return refusals[0] < 0 and place(*args)

    monkeypatch.setattr(env.simulation, "place_ego", jammed)


def test_a_jammed_start_cuts_every_egos_episode_and_the_road_starts_again(monkeypatch):
    road = RespawningRoad(SMALL_CONFIG, egos=3, seed=5)
    try:
        road.reset()
        jam_next_respawn(monkeypatch, road.env)
        rng = np.random.default_rng(0)
        for _ in range(400):
            observations, _, dones, infos = road.step(rng.integers(0, 5, size=3).tolist())
            if dones.any():
                break
        assert dones.all(), "one ego found no place to respawn: every ego's episode is cut"
        assert sum(info["TimeLimit.truncated"] and info["termination"] not in ("end_of_road", "time_limit")
                   for info in infos) >= 2, "the egos still driving are truncated by the jam"
        assert all(info["terminal_observation"].shape == (56,) for info in infos)
        assert sorted(road.env.agents) == sorted(road.env.possible_agents), "the road started again with every ego"
        assert observations.shape == (3, 56)
    finally:
        road.close()


def test_rail_lives_go_on_after_a_jam_within_each_egos_budget(monkeypatch, small_config):
    env = ParallelHighwayEnv(3, small_config, transport="libsumo")
    try:
        env.reset(seed=5)
        jam_next_respawn(monkeypatch, env)
        lives = drive_egos(env, [lambda observation, traffic: int(Action.ACCELERATE)] * 3, 5, 300)
    finally:
        env.close()
    for ego_lives in lives:
        assert sum(life.metrics["steps"] for life in ego_lives) == 300
        assert len(ego_lives) >= 2
    cut = [life.metrics for ego_lives in lives for life in ego_lives
           if life.metrics["truncated"] and life.metrics["termination"] not in ("end_of_road", "time_limit")]
    assert len(cut) >= 2, "the jam cut the lives of the egos still driving"


def test_a_jam_cuts_only_the_episodes_the_step_did_not_end(monkeypatch, small_config):
    """At a jam, the egos still driving are cut (`RespawnStep.cut`); those whose episode the step itself ended are
    not, so a collision stays a termination only."""
    env = ParallelHighwayEnv(3, small_config, transport="libsumo")
    try:
        road = RespawningEgos(env, 5, reset_when_empty=False)
        road.start()
        jam_next_respawn(monkeypatch, env)
        for _ in range(400):
            step = road.step(dict.fromkeys(env.agents, int(Action.ACCELERATE)))
            if step.ended:
                break
    finally:
        env.close()
    by_step = {agent for agent in step.terminations if step.terminations[agent] or step.truncations[agent]}
    assert by_step and step.cut and by_step.isdisjoint(step.cut)
    assert set(step.ended) == by_step | set(step.cut) == set(env.possible_agents)
    assert all(step.truncated(agent) == step.truncations[agent] for agent in by_step)


def test_a_lone_egos_lives_respawn_on_the_same_road_without_a_reset(small_config):
    """`drive_egos` with a budget: when every ego's episode ends at one step (here the one ego's), each respawns in
    the traffic as it is (a new vehicle, the road's clock running on), the road is not reset."""
    import libsumo

    env = ParallelHighwayEnv(1, small_config.with_overrides({"env": {"max_episode_s": 1.0}}), transport="libsumo")
    try:
        env.reset(seed=5)
        start_s = env.simulation.time_s
        lives = drive_egos(env, [lambda observation, traffic: int(Action.KEEP)], 5, 6)
        period_s = small_config.env.decision_period_s
        assert [life.metrics["steps"] for life in lives[0]] == [2, 2, 2]
        assert env.simulation.time_s == pytest.approx(start_s + 6 * period_s)
        assert "ego_0.2" in libsumo.vehicle.getIDList()
    finally:
        env.close()


def _closes(close, processes) -> bool:
    """Whether `close()` ends, stopping `processes`, within a bound on a hang (not on speed); a hung one is killed."""
    closing = threading.Thread(target=close, daemon=True)
    closing.start()
    closing.join(60)
    for process in processes:
        if process.is_alive():
            os.kill(process.pid, signal.SIGKILL)
    return not closing.is_alive()


def test_env_processes_are_stopped_though_they_ignore_sigterm(tmp_path):
    """A hung env process (stopped: it answers nothing) is killed when the VecEnv closes, and after a lost env the
    others, waiting for orders, are killed without asking: SIGTERM, which they ignore, would leave them running."""
    venv = driving_processes(SMALL_CONFIG, processes=3, egos=1, seed=3, error_dir=tmp_path)
    venv.reset()
    os.kill(venv.processes[1].pid, signal.SIGSTOP)
    processes = list(venv.processes)
    assert _closes(venv.close, processes) and not any(process.is_alive() for process in processes)
    venv = driving_processes(SMALL_CONFIG, processes=3, egos=1, seed=3, error_dir=tmp_path)
    venv.reset()
    processes = list(venv.processes)
    assert _closes(lambda: close_envs(venv, lost=True), processes)
    assert not any(process.is_alive() for process in processes)
