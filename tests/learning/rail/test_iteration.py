"""One RAIL iteration on a fake backend that answers rollout tasks with made-up trajectories (no SUMO)."""

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.iteration import (
    RailSettings,
    TrainingState,
    Trajectory,
    agreement_returns,
    run_iteration,
    run_rollouts,
)
from sumo_rail.learning.rail.noise import directions
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.runners.backends import RolloutBackend, SerialBackend
from sumo_rail.runners.tables import Demonstrations
from sumo_rail.sim.observation import observation_space

SIZE = 6


class FakeBackend(RolloutBackend):
    """Keeps the tasks; each episode's trajectory is drawn from its seed, so equal seeds give equal traffic."""

    def __init__(self) -> None:
        self.workers = 1
        self.tasks = []

    def run(self, tasks, on_result=None):
        self.tasks += list(tasks)
        return [[[self.trajectory(seed, sign * index, task.expert is not None and sign > 0)
                  for seed in task.episode_seeds] for index, sign in task.members] for task in tasks]

    @staticmethod
    def trajectory(seed: int, offset: int, agreeing: bool) -> Trajectory:
        """Made-up decisions; when the task asked an expert, it agrees with every decision of the positive signs
        and with none of the negative ones."""
        rng = np.random.default_rng(seed)
        steps = int(rng.integers(5, 9))
        observations = (rng.normal(size=(steps, SIZE)) + 0.1 * offset).astype(np.float32)
        actions = rng.integers(0, 5, steps)
        return Trajectory(observations, actions, False, steps, actions if agreeing else (actions + 1) % 5)

    def close(self) -> None:
        pass


def iterate(settings: RailSettings) -> tuple[FakeBackend, TrainingState, TrainingState]:
    shape = PolicyShape("linear", SIZE)
    rng = np.random.default_rng(0)
    expert = Demonstrations(rng.normal(size=(50, SIZE)).astype(np.float32), rng.integers(0, 5, 50), np.zeros(50), {})
    stats = RunningStats.of(expert.observations)
    start = TrainingState.start(np.zeros(shape.parameter_count, np.float32), stats, settings)
    state = TrainingState.start(np.zeros(shape.parameter_count, np.float32), stats, settings)
    discriminator = Discriminator(SIZE, stats.mean.copy(), stats.std.copy(),
                                  DiscriminatorSettings(steps_per_iteration=2))
    backend = FakeBackend()
    run_iteration(state, shape, Config(), settings, discriminator, expert, backend)
    return backend, start, state


def test_common_traffic_drives_every_direction_on_the_same_episodes():
    backend, _, _ = iterate(RailSettings(directions=4, episodes_per_rollout=2, common_traffic=True))
    seeds = {task.episode_seeds for task in backend.tasks}
    assert len(backend.tasks) == 8 and len(seeds) == 1 and len(next(iter(seeds))) == 2


def test_independent_traffic_gives_each_direction_its_own_episodes_for_both_signs():
    backend, _, _ = iterate(RailSettings(directions=4))  # the default
    by_direction = {}
    for task in backend.tasks:
        by_direction.setdefault(task.members[0][0], set()).add(task.episode_seeds)
    assert all(len(seeds) == 1 for seeds in by_direction.values())   # both signs share a direction's seeds
    assert len(set().union(*by_direction.values())) == 4             # directions do not share them


def test_frozen_normalizer_keeps_the_starting_statistics():
    _, start, frozen = iterate(RailSettings(directions=2))  # the default
    _, _, merged = iterate(RailSettings(directions=2, freeze_normalizer=False))
    assert frozen.stats.count == start.stats.count and np.array_equal(frozen.stats.mean, start.stats.mean)
    assert merged.stats.count > start.stats.count
    assert not np.array_equal(frozen.parameters, start.parameters)  # the search itself still moves


def test_top_defaults_to_half_the_directions_for_any_n():
    assert [RailSettings(directions=n).kept for n in (1, 8, 9, 32)] == [1, 4, 5, 16]
    with pytest.raises(ValueError, match=r"rail\.top must be between 1 and rail\.directions"):
        RailSettings(directions=8, top=9)
    with pytest.raises(ValueError, match=r"rail\.episodes_per_rollout"):
        RailSettings(episodes_per_rollout=0)


def test_the_agreement_reward_asks_the_expert_and_climbs_agreement():
    backend, start, state = iterate(RailSettings(directions=4, top=4, reward="agreement"))
    assert all(task.expert is not None for task in backend.tasks)
    assert all(task.expert is None for task in iterate(RailSettings(directions=4))[0].tasks)  # RAIL never asks
    # every + rollout agrees fully, every - never: the step is the sum of the directions
    total = directions(0, 0, 4, start.parameters.size).sum(axis=0).astype(np.float64)
    step = (state.parameters - start.parameters).astype(np.float64)
    assert step @ total / np.linalg.norm(step) / np.linalg.norm(total) == pytest.approx(1.0, abs=1e-5)
    with pytest.raises(ValueError, match=r"rail\.reward must be one of"):
        RailSettings(reward="oracle")


def test_shared_rollouts_drive_each_ego_by_its_own_perturbation_in_task_order(small_config):
    """Two egos per simulation: each rollout comes back in the order of one-ego rollouts, every ego's decisions are
    its own perturbed policy's, and the same seeds give the same trajectories."""
    size = observation_space(small_config).shape[0]
    shape = PolicyShape("linear", size)
    policy = Policy(shape, np.random.default_rng(0).normal(0, 0.3, shape.parameter_count).astype(np.float32))
    seeds = [(2,), (5,)]
    with SerialBackend() as backend:
        shared = run_rollouts(policy, small_config, 7, 0, 0.5, seeds, None, 2, backend)
        again = run_rollouts(policy, small_config, 7, 0, 0.5, seeds, None, 2, backend)
    assert len(shared) == 4 and all(len(rollout) == 1 for rollout in shared)
    for (index, sign), (trajectory,) in zip([(0, 1), (0, -1), (1, 1), (1, -1)], shared, strict=True):
        delta = directions(7, 0, 2, shape.parameter_count)[index]
        perturbed = Policy(shape, policy.parameters + np.float32(sign * 0.5) * delta)
        assert trajectory.steps == len(trajectory.actions) > 0
        assert np.array_equal(np.argmax(perturbed.logits(trajectory.observations), axis=1), trajectory.actions)
    assert all(np.array_equal(a[0].observations, b[0].observations) for a, b in zip(shared, again, strict=True))
    assert not np.array_equal(shared[0][0].observations[:5], shared[1][0].observations[:5])  # two egos, two places


def test_a_rollout_of_decisions_drives_its_ego_for_its_budget_across_lives(small_config):
    """Four egos on one road, each respawning until it has made 400 decisions (an episode of the small road lasts
    at most ~220 at 10 m/s): every rollout is its budget, in lives its own perturbed policy drove, and the same seeds
    give the same lives."""
    size = observation_space(small_config).shape[0]
    shape = PolicyShape("linear", size)
    policy = Policy(shape, np.random.default_rng(0).normal(0, 0.3, shape.parameter_count).astype(np.float32))
    with SerialBackend() as backend:
        rollouts = run_rollouts(policy, small_config, 7, 0, 0.5, [(2,), (5,)], None, 4, backend, decisions=400)
        again = run_rollouts(policy, small_config, 7, 0, 0.5, [(2,), (5,)], None, 4, backend, decisions=400)
    assert len(rollouts) == 4
    for (index, sign), lives in zip([(0, 1), (0, -1), (1, 1), (1, -1)], rollouts, strict=True):
        assert sum(life.steps for life in lives) == 400 and len(lives) >= 2  # it respawned
        delta = directions(7, 0, 2, shape.parameter_count)[index]
        perturbed = Policy(shape, policy.parameters + np.float32(sign * 0.5) * delta)
        for life in lives:
            assert np.array_equal(np.argmax(perturbed.logits(life.observations), axis=1), life.actions)
    assert [[life.observations.tobytes() for life in lives] for lives in rollouts] == [
        [life.observations.tobytes() for life in lives] for lives in again]


def test_a_rollout_of_decisions_scores_its_reward_per_decision_not_per_life():
    def life(steps: int, agreeing: bool) -> Trajectory:
        actions = np.zeros(steps, np.int64)
        return Trajectory(np.zeros((steps, SIZE), np.float32), actions, False, steps, actions + (0 if agreeing else 1))
    rollouts = [[life(10, True), life(30, False)]]
    assert agreement_returns(rollouts, 600)[0] == 0.5  # episodes: each counts alike
    assert agreement_returns(rollouts, 600, per_decision=True)[0] == 0.25  # decisions: 10 of 40 agree
    crashed = [[life(10, True), Trajectory(np.zeros((30, SIZE), np.float32), np.zeros(30, np.int64), True, 30,
                                           np.ones(30, np.int64))]]
    assert agreement_returns(crashed, 100, per_decision=True)[0] == 10 / 110  # the crash fills its life to 100
    with pytest.raises(ValueError, match=r"rail\.rollout_decisions"):
        RailSettings(rollout_decisions=200, episodes_per_rollout=2)


@pytest.mark.parametrize("egos", [1, 2, 4])
def test_a_mix_of_roads_puts_both_signs_of_a_direction_on_one_road(egos):
    roads = ("straight", "exit", "merge")
    backend, _, _ = iterate(RailSettings(directions=6, egos=egos, roads=roads))
    found: dict[int, set[str]] = {}
    for task in backend.tasks:
        assert task.config.scenario.kind == roads[task.members[0][0] % len(roads)]  # the first direction's road
        for index, _ in task.members:
            found.setdefault(index, set()).add(task.config.scenario.kind)
    assert sorted(found) == list(range(6)) and all(len(kinds) == 1 for kinds in found.values())
    assert set().union(*found.values()) == set(roads)
    alone, _, _ = iterate(RailSettings(directions=6, egos=egos))
    assert {task.config.scenario.kind for task in alone.tasks} == {"straight"}
