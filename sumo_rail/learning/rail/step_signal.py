"""The meter of an ARS step, measured without training: how much of the step two independent draws of traffic agree
on (its signal), and whether the directions the reward prefers are those that raise agreement with the expert (its
alignment).

For a policy theta, N directions delta_k and a perturbation scale nu, each of two draws A and B runs the 2N rollouts
of theta +- nu delta_k on its own traffic (within a draw both signs of a direction share their episodes, as in
training) and asks the expert at every decision what it would have done. Per direction k and draw d this gives the
reward difference r+_k - r-_k (for each reward, e.g. each discriminator) and the agreement difference g+_k - g-_k
(share of decisions the expert would have made alike). Then, with 95% intervals:
- signal: the correlation across directions of draw A's and draw B's differences (0 where the returns ignore the
  parameters, 1 where the traffic does not matter), and the cosine between the two draws' ARS steps;
- alignment: the correlation of the reward differences of one draw with the agreement differences of the other
  (across draws, so the noise the two share within a draw does not count; the mean of A-B and B-A), the same within
  draws, and the cosine between the reward's ARS step and the agreement's step (across draws).
A reward can only lead the search to the expert where both its signal and its alignment are well above 0.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sumo_rail.drivers.policies import Policy
from sumo_rail.learning.rail.ars import ars_update
from sumo_rail.learning.rail.iteration import (
    RailSettings,
    Trajectory,
    agreement_returns,
    discriminator_returns,
    run_rollouts,
)
from sumo_rail.learning.rail.noise import directions, flip_rate
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.seeding import Purpose, episode_seeds

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
    from sumo_rail.runners.backends import RolloutBackend
    from sumo_rail.runners.rollout import DriverSpec

REWARD_VARIANTS: dict[str, dict[str, Any]] = {
    "given": {},
    "contrast": {"reward_form": "contrast"},
    "balanced": {"balance": 1.0},
    "balanced-contrast": {"balance": 1.0, "reward_form": "contrast"},
    "penalty": {"gradient_penalty": 10.0},
}
"""Discriminators the meter compares, as changes to the given `DiscriminatorSettings` ("given": none)."""
CONFIDENCE = 0.95
RESAMPLES = 2000
"""Bootstrap resamples of the directions behind each interval."""


@dataclass(frozen=True)
class Estimate:
    """A statistic with its 95% bootstrap interval (percentile, resampling directions)."""

    value: float
    low: float
    high: float

    def to_dict(self) -> dict[str, float]:
        return {"value": self.value, "low": self.low, "high": self.high}


@dataclass(frozen=True)
class Differences:
    """One measure's returns of theta + nu delta_k and theta - nu delta_k in two draws, each shape (2, N)."""

    plus: np.ndarray
    minus: np.ndarray

    def to_dict(self) -> dict[str, list[list[float]]]:
        return {"plus": self.plus.tolist(), "minus": self.minus.tolist()}

    @property
    def differences(self) -> np.ndarray:
        """r+ - r-, shape (2, N): row d is draw d."""
        return self.plus - self.minus


def correlation(x: np.ndarray, y: np.ndarray) -> float:
    """Pearson's correlation; NaN when either is constant."""
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan")
    return float(np.corrcoef(x, y)[0, 1])


def cosine(u: np.ndarray, v: np.ndarray) -> float:
    """Cosine of the angle between two vectors; NaN when either is zero."""
    u, v = np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64)
    norms = np.linalg.norm(u) * np.linalg.norm(v)
    return float(u @ v / norms) if norms > 0 else float("nan")


def ars_step(deltas: np.ndarray, plus: np.ndarray, minus: np.ndarray, top: int, shaping: str) -> np.ndarray:
    """The direction of the ARS step (`ars_update` from zero with step size 1) that these returns give."""
    kept = min(top, len(deltas))
    return ars_update(np.zeros(deltas.shape[1], np.float32), deltas, plus, minus, kept, 1.0, shaping).parameters


def bootstrap(statistic: Callable[[np.ndarray], float], count: int, seed: int) -> Estimate:
    """`statistic` of the direction indices 0..count-1 and its interval over resampled directions."""
    value = statistic(np.arange(count))
    rng = np.random.default_rng(seed)
    replicates = np.array([statistic(rng.integers(count, size=count)) for _ in range(RESAMPLES)])
    replicates = replicates[np.isfinite(replicates)]
    if not np.isfinite(value) or len(replicates) < RESAMPLES / 2:
        return Estimate(value, float("nan"), float("nan"))
    low, high = np.quantile(replicates, [(1 - CONFIDENCE) / 2, (1 + CONFIDENCE) / 2])
    return Estimate(value, float(low), float(high))


def signal(deltas: np.ndarray, measure: Differences, top: int, shaping: str, seed: int = 0) -> dict[str, Estimate]:
    """How much of one measure's step the two draws agree on: `correlation` of their differences across directions
    and `step_cosine` of their ARS steps."""
    d = measure.differences

    def step(draw: int, rows: np.ndarray) -> np.ndarray:
        return ars_step(deltas[rows], measure.plus[draw, rows], measure.minus[draw, rows], top, shaping)

    return {"correlation": bootstrap(lambda rows: correlation(d[0, rows], d[1, rows]), len(deltas), seed),
            "step_cosine": bootstrap(lambda rows: cosine(step(0, rows), step(1, rows)), len(deltas), seed)}


def alignment(deltas: np.ndarray, reward: Differences, agreement: Differences, top: int, shaping: str,
              seed: int = 0) -> dict[str, Estimate]:
    """Whether the directions a reward prefers raise agreement with the expert: the correlation of one draw's reward
    differences with the other draw's agreement differences (`across`, mean of both pairings), the same within each
    draw (`within`), and the cosine between the reward's and the agreement's ARS steps across draws (`step_cosine`)."""
    r, g = reward.differences, agreement.differences

    def across(rows: np.ndarray) -> float:
        return float(np.mean([correlation(r[0, rows], g[1, rows]), correlation(r[1, rows], g[0, rows])]))

    def within(rows: np.ndarray) -> float:
        return float(np.mean([correlation(r[0, rows], g[0, rows]), correlation(r[1, rows], g[1, rows])]))

    def steps(rows: np.ndarray) -> float:
        reward_steps = [ars_step(deltas[rows], reward.plus[d, rows], reward.minus[d, rows], top, shaping)
                        for d in (0, 1)]
        agreement_steps = [ars_step(deltas[rows], agreement.plus[d, rows], agreement.minus[d, rows], top, shaping)
                           for d in (0, 1)]
        return float(np.mean([cosine(reward_steps[0], agreement_steps[1]),
                              cosine(reward_steps[1], agreement_steps[0])]))

    count = len(deltas)
    return {"across": bootstrap(across, count, seed), "within": bootstrap(within, count, seed),
            "step_cosine": bootstrap(steps, count, seed)}


Rollouts = list[list[list[Trajectory]]]
"""rollouts[draw][2 k + (0 for +, 1 for -)]: the trajectories of one rollout (one per episode)."""


def draw_seeds(settings: RailSettings, draw: int) -> list[tuple[int, ...]]:
    """Episode seeds of each direction in one draw: `episodes_per_rollout` per direction, or with common traffic one
    set that every direction drives. Draws with different numbers never share an episode."""
    per_rollout, sets = settings.episodes_per_rollout, 1 if settings.common_traffic else settings.directions
    rng = np.random.default_rng(np.random.SeedSequence(settings.seed, spawn_key=(draw,)))
    base = int(rng.integers(2**30)) * sets * per_rollout
    drawn = episode_seeds(Purpose.TRAIN, base, sets * per_rollout)
    return [tuple(drawn[(0 if settings.common_traffic else k) * per_rollout:][:per_rollout])
            for k in range(settings.directions)]


def run_draws(policy: Policy, config: Config, settings: RailSettings, nu: float, expert: DriverSpec | None,
              backend: RolloutBackend, draws: Sequence[int] = (0, 1), iteration: int = 0,
              on_rollout: Callable[[int, Any], None] | None = None) -> Rollouts:
    """The 2N rollouts of theta +- nu delta_k (directions of `iteration` with noise seed `settings.seed`) in each
    draw, the expert (when given) asked at every decision. The same draw number twice gives the same traffic
    twice."""
    rollouts = []
    for draw in draws:
        seeds = draw_seeds(settings, draw)
        rollouts.append(run_rollouts(policy, config, settings.seed, iteration, nu, seeds, expert, settings.egos,
                                     backend, on_rollout, settings.rollout_decisions))
    return rollouts


def agreement_differences(rollouts: Rollouts, horizon: int, per_decision: bool = False) -> Differences:
    """Each rollout's agreement with the expert (`iteration.agreement_returns`: the share of its decisions the expert
    would have made alike; `per_decision` for rollouts of a budget of decisions)."""
    return _differences([agreement_returns(draw, horizon, per_decision) for draw in rollouts])


def reward_differences(rollouts: Rollouts, discriminator: Discriminator, horizon: int,
                       per_decision: bool = False) -> Differences:
    """Each rollout's return as RAIL scores it (`iteration.discriminator_returns`)."""
    return _differences([discriminator_returns(draw, discriminator, horizon, per_decision) for draw in rollouts])


def _differences(returns: list[np.ndarray]) -> Differences:
    scores = np.stack(returns)
    return Differences(scores[:, 0::2], scores[:, 1::2])


def pairs(rollouts: Rollouts) -> tuple[np.ndarray, np.ndarray]:
    """All (observation, action) pairs of the rollouts, as the discriminator trains on them."""
    trajectories = [t for draw in rollouts for rollout in draw for t in rollout]
    return (np.concatenate([t.observations for t in trajectories]),
            np.concatenate([t.actions for t in trajectories]))


@dataclass(frozen=True)
class Meter:
    """The meter's settings beyond the ARS settings (`RailSettings`: N, b, nu or the flip rate, episodes per
    rollout, traffic, fitness shaping, seed)."""

    warmup_rounds: int = 5
    """Training calls of each discriminator before the measured iteration, each on fresh perturbed rollouts of the
    policy (as after this many RAIL iterations at theta)."""
    warmup_directions: int = 8
    """Directions (both signs, one episode each) of each warm-up round."""

    def rollouts(self, settings: RailSettings) -> int:
        """Rollouts `measure` runs: the warm-up's and the two draws' 2N each."""
        return self.warmup_rounds * 2 * self.warmup_directions + 2 * 2 * settings.directions


def variants(settings: DiscriminatorSettings, names: Sequence[str], expert_observations: np.ndarray
             ) -> dict[str, Discriminator]:
    """A fresh discriminator per REWARD_VARIANTS name, normalised by the expert's statistics as in training."""
    from sumo_rail.learning.rail.discriminator import Discriminator

    expert = RunningStats.of(expert_observations)
    return {name: Discriminator(expert_observations.shape[1], expert.mean.copy(), expert.std.copy(),
                                dataclasses.replace(settings, **REWARD_VARIANTS[name])) for name in names}


def warm_up(discriminators: dict[str, Discriminator], policy: Policy, config: Config, settings: RailSettings,
            nu: float, expert_pairs: tuple[np.ndarray, np.ndarray], meter: Meter, backend: RolloutBackend,
            on_rollout: Callable[[int, Any], None] | None = None) -> None:
    """Train every discriminator `meter.warmup_rounds` times, round i on the rollouts of the directions of iteration
    i + 1 (the measured draws use iteration 0) in traffic of draws 2 + i, in place."""
    warm = RailSettings(directions=meter.warmup_directions, seed=settings.seed)
    for round_ in range(meter.warmup_rounds):
        rollouts = run_draws(policy, config, warm, nu, None, backend, (2 + round_,), 1 + round_, on_rollout)
        observations, actions = pairs(rollouts)
        for discriminator in discriminators.values():
            discriminator.train(*expert_pairs, observations, actions)


def measure(policy: Policy, config: Config, settings: RailSettings, nu: float, expert: DriverSpec,
            discriminators: dict[str, Discriminator], expert_pairs: tuple[np.ndarray, np.ndarray],
            calibration: np.ndarray, backend: RolloutBackend, meter: Meter = Meter(),
            on_rollout: Callable[[int, Any], None] | None = None) -> dict[str, Any]:
    """The meter's report for one policy and setting: nu, the flip rate on `calibration` states, the agreement's
    own signal, and each named discriminator's signal and alignment (each warmed up, then trained once on the
    measured draws' pairs and scoring them, as a RAIL iteration does); `returns` keeps every rollout's return per
    measure (draw x direction), so other step settings (b, fitness shaping) can be scored afterwards."""
    deltas = directions(settings.seed, 0, settings.directions, policy.shape.parameter_count)
    warm_up(discriminators, policy, config, settings, nu, expert_pairs, meter, backend, on_rollout)
    rollouts = run_draws(policy, config, settings, nu, expert, backend, on_rollout=on_rollout)
    horizon = round(config.env.max_episode_s / config.env.decision_period_s)
    per_decision = settings.rollout_decisions is not None
    agreement = agreement_differences(rollouts, horizon, per_decision)
    top, shaping = settings.kept, settings.fitness
    observations, actions = pairs(rollouts)
    report: dict[str, Any] = {
        "nu": nu, "flip_rate": flip_rate(policy, deltas, nu, calibration),
        "decisions": len(actions),
        "agreement_mean": float(np.mean([agreement.plus, agreement.minus])),
        "agreement": {key: value.to_dict() for key, value in signal(deltas, agreement, top, shaping).items()},
        "rewards": {},
        "returns": {"agreement": agreement.to_dict()},
    }
    for name, discriminator in discriminators.items():
        discriminator.train(*expert_pairs, observations, actions)
        returns = reward_differences(rollouts, discriminator, horizon, per_decision)
        report["returns"][name] = returns.to_dict()
        report["rewards"][name] = {
            "signal": {key: value.to_dict() for key, value in signal(deltas, returns, top, shaping).items()},
            "alignment": {key: value.to_dict()
                          for key, value in alignment(deltas, returns, agreement, top, shaping).items()},
        }
    return report
