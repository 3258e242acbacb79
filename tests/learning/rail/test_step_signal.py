"""The meter of an ARS step: returns that ignore the parameters read about 0, a deterministic setting reads 1, and a
reward that follows agreement reads as aligned (pure statistics, then one small real SUMO measurement)."""

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.rail import step_signal
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.step_signal import (
    REWARD_VARIANTS,
    Differences,
    agreement_differences,
    alignment,
    draw_seeds,
    reward_differences,
    run_draws,
    signal,
    variants,
)
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.rollout import ExpertDriver
from sumo_rail.sim.observation import observation_space

DIRECTIONS, SIZE = 300, 40


def returns(rng: np.random.Generator, parts: np.ndarray | None = None, noise: float = 1.0) -> Differences:
    """Two draws of r+- = +-parts / 2 + independent noise; without parts the returns ignore the directions."""
    half = np.zeros(DIRECTIONS) if parts is None else parts / 2
    shape = (2, DIRECTIONS)
    return Differences(half + noise * rng.normal(size=shape), -half + noise * rng.normal(size=shape))


@pytest.fixture
def deltas() -> np.ndarray:
    return np.random.default_rng(1).standard_normal((DIRECTIONS, SIZE)).astype(np.float32)


def test_returns_that_ignore_the_parameters_have_no_signal(deltas):
    measured = signal(deltas, returns(np.random.default_rng(0)), top=DIRECTIONS // 2, shaping="std")
    for estimate in measured.values():
        assert estimate.low < 0 < estimate.high
        assert abs(estimate.value) < 0.15


def test_the_same_returns_in_both_draws_have_full_signal(deltas):
    rng = np.random.default_rng(0)
    plus, minus = rng.normal(size=DIRECTIONS), rng.normal(size=DIRECTIONS)
    measured = signal(deltas, Differences(np.stack([plus, plus]), np.stack([minus, minus])), top=10, shaping="rank")
    assert measured["correlation"].value == pytest.approx(1.0)
    assert measured["step_cosine"].value == pytest.approx(1.0)


def test_a_signal_half_as_large_as_the_noise_reads_between_the_two(deltas):
    rng = np.random.default_rng(2)
    measured = signal(deltas, returns(rng, rng.normal(size=DIRECTIONS)), top=DIRECTIONS, shaping="std")
    # r+ - r- = parts + noise with var(noise) = 2 var(parts): correlation between draws 1 / 3
    assert measured["correlation"].low < 1 / 3 < measured["correlation"].high
    assert measured["correlation"].low > 0.1


def test_a_reward_that_follows_agreement_is_aligned_and_an_unrelated_one_is_not(deltas):
    rng = np.random.default_rng(3)
    effect = rng.normal(size=DIRECTIONS)
    agreement = returns(rng, effect, noise=0.3)
    follows = alignment(deltas, returns(rng, 2.0 * effect + 1.0, noise=0.3), agreement, DIRECTIONS // 2, "std")
    unrelated = alignment(deltas, returns(rng, rng.normal(size=DIRECTIONS), noise=0.3), agreement, DIRECTIONS // 2,
                          "std")
    assert follows["across"].low > 0.7 and follows["step_cosine"].low > 0.5
    assert unrelated["across"].low < 0 < unrelated["across"].high
    assert unrelated["step_cosine"].low < 0 < unrelated["step_cosine"].high


def test_draws_never_share_episodes_and_common_traffic_shares_them_across_directions():
    independent = RailSettings(directions=4, episodes_per_rollout=2)
    first, second = draw_seeds(independent, 0), draw_seeds(independent, 1)
    assert len({seed for seeds in first for seed in seeds}) == 8
    assert not {seed for seeds in first for seed in seeds} & {seed for seeds in second for seed in seeds}
    assert len(set(draw_seeds(RailSettings(directions=4, episodes_per_rollout=2, common_traffic=True), 0))) == 1


def test_the_same_traffic_twice_reads_full_signal_in_sumo(small_config: Config):
    """Real rollouts: draw 0 twice is a deterministic setting (signal 1); draws 0 and 1 differ."""
    config = small_config.with_overrides({"scenario": {"length_m": 900.0}})
    size = observation_space(config).shape[0]
    shape = PolicyShape("linear", size)
    policy = Policy(shape, np.random.default_rng(0).normal(0, 0.3, shape.parameter_count).astype(np.float32))
    settings = RailSettings(directions=4)
    with SerialBackend() as backend:
        same = run_draws(policy, config, settings, 0.5, ExpertDriver(), backend, draws=(0, 0))
        other = run_draws(policy, config, settings, 0.5, ExpertDriver(), backend, draws=(0, 1))
    trajectory = same[0][0][0]
    assert trajectory.expert_actions is not None and len(trajectory.expert_actions) == len(trajectory.actions)
    agreement = agreement_differences(same, horizon=600)
    assert np.all((agreement.plus >= 0) & (agreement.plus <= 1))
    np.testing.assert_array_equal(agreement.plus[0], agreement.plus[1])
    deltas = np.random.default_rng(0).standard_normal((4, shape.parameter_count)).astype(np.float32)
    assert signal(deltas, agreement, 2, "std")["correlation"].value == pytest.approx(1.0)
    observations = np.concatenate([t.observations for t in same[0][0]])
    discriminator = variants(DiscriminatorSettings(), ["contrast"], observations)["contrast"]
    rewards = reward_differences(same, discriminator, horizon=600)
    np.testing.assert_array_equal(rewards.plus[0], rewards.plus[1])
    assert not np.array_equal(reward_differences(other, discriminator, 600).plus[0],
                              reward_differences(other, discriminator, 600).plus[1])


def test_every_reward_variant_builds_a_discriminator():
    observations = np.random.default_rng(0).normal(size=(50, 6)).astype(np.float32)
    built = variants(DiscriminatorSettings(), list(REWARD_VARIANTS), observations)
    assert built["contrast"].settings.reward_form == "contrast" and built["balanced"].settings.balance == 1.0
    assert built["given"].settings == DiscriminatorSettings()


def test_the_correlation_interval_covers_a_known_correlation_as_often_as_it_says(monkeypatch):
    """200 synthetic measurements of 80 directions whose draws correlate 1/3 (r+ - r- = parts + noise, var(noise) =
    2 var(parts)): the 95% interval holds 1/3 in 91-97.5% of them (a 90% or 99% interval would not); fewer resamples
    than the meter's keep it quick."""
    monkeypatch.setattr(step_signal, "RESAMPLES", 400)
    directions, trials, covered = 80, 200, 0
    for trial in range(trials):
        rng = np.random.default_rng(100 + trial)
        half = rng.normal(size=directions) / 2
        d = Differences(half + rng.normal(size=(2, directions)), -half + rng.normal(size=(2, directions))).differences
        estimate = step_signal.bootstrap(lambda rows, d=d: step_signal.correlation(d[0, rows], d[1, rows]),
                                         directions, trial)
        covered += estimate.low < 1 / 3 < estimate.high
    assert 0.91 <= covered / trials <= 0.975
