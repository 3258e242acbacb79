"""RAIL training (the paper's Algorithm 1): ARS in parameter space with an LS-GAN discriminator's reward.

One iteration t:
1. the learner draws N direction indices (the vectors come from `noise.direction(noise_seed, t, k)`) and the
   SUMO episode seeds: a set of `episodes_per_rollout` seeds per direction, both signs sharing it (the default,
   as in the first implementation), or with common traffic one set that every direction and sign drives, so
   directions differ by their parameters only (common random numbers). Workers run the 2N rollouts of
   theta +- nu * delta_k with the observation statistics frozen for the iteration, `egos` of them on one road
   (`RolloutTask`); a rollout is whole episodes (its return the mean over them), or with `rollout_decisions` a
   budget of decisions of its ego across as many lives as it takes (`rollout.drive_egos`: no ego waits for
   another; its return the mean per decision);
2. the discriminator takes its LS-GAN steps on the expert's pairs and this iteration's rollout pairs;
3. each rollout's return is the mean of r = log D - log(1 - D) over its decisions, as the paper's expectation;
   a collision fills the decisions it cut short, up to the episode limit, with the lowest reward the clipped
   D can give, so ending early never pays (a slower but safe driver is not favoured by more decisions either,
   since the return is a mean);
4. the ARS step moves theta along the top-b directions; the observation statistics merge this iteration's
   states (in task order, so the result does not depend on the number of workers) unless they are frozen at
   BC's; every eta iterations nu grows by tau if the best mean return did not improve, else returns to nu_init.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from sumo_rail.bounds import bounded, check_fields, given
from sumo_rail.config import Config
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.rail.ars import FITNESS_SHAPINGS, NoiseAdaptation, adapt_noise, ars_update
from sumo_rail.learning.rail.noise import direction, directions, noise_for_flip_rate
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.runners.road_mix import road_configs
from sumo_rail.runners.rollout import (
    Driver,
    DriverSpec,
    EpisodeResult,
    ExpertDriver,
    drive_egos,
    run_shared_episode,
    shared_groups,
)
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.traffic import TrafficView

if TYPE_CHECKING:
    from sumo_rail.learning.rail.discriminator import Discriminator
    from sumo_rail.runners.backends import RolloutBackend, WorkerContext
    from sumo_rail.runners.tables import Demonstrations


REWARDS = ("discriminator", "agreement")
"""What scores a rollout (`RailSettings.reward`)."""
MAX_DIRECTIONS = 4096
"""The most directions an iteration may have (`RailSettings.directions`): 8 times the paper's largest, 8192 rollouts
an iteration."""


@dataclass(frozen=True)
class RailSettings:
    """ARS hyper-parameters (defaults from the paper where it gives them)."""

    directions: int = bounded(1, MAX_DIRECTIONS, default=32)
    """N, directions per iteration (the paper uses 8 to 512)."""
    top: int | None = bounded(1, MAX_DIRECTIONS, default=None, integer=True)
    """b, directions kept for the update, at most N; None: N / 2 (rounded up)."""
    step_size: float = bounded(0, 1, default=0.02, low_open=True)
    """alpha. The paper's 0.001 changes no decision of a BC-initialised policy in several iterations at N = 32
    (docs/results.md, "RAIL ablations"), so the default deviates from it."""
    noise: NoiseAdaptation = field(default_factory=NoiseAdaptation)
    """nu_init 0.03, tau 0.001, eta."""
    seed: int = given("--seed", 0)
    common_traffic: bool = False
    """All directions and signs of an iteration drive the same episode seeds (common random numbers); the default,
    each direction its own (both signs share them), imitates better on validation episodes (docs/results.md, "RAIL
    ablations")."""
    episodes_per_rollout: int = bounded(1, 100, default=1)
    """Episodes each rollout drives; its return is their mean."""
    freeze_normalizer: bool = True
    """Keep the observation statistics the run started with (BC's, or the demonstrations' without BC); False merges
    every rollout's states into them, as the paper does. Frozen was best on validation episodes (docs/results.md,
    "RAIL ablations")."""
    fitness: str = "std"
    """How the step scales the returns: 'std' divides by sigma_R (ARS, the paper); 'rank' uses centred ranks
    (Salimans et al. 2017), `ars.centred_ranks`."""
    reward: str = "discriminator"
    """'discriminator': RAIL's reward. 'agreement': a control, not imitation from demonstrations: the expert is asked
    at every decision of every rollout (as DAgger asks it) and a rollout's return is the share of its decisions the
    expert would have made alike, the reward every discriminator stands in for; what the search reaches with it
    bounds what it can reach with any reward at the same budget."""
    egos: int = bounded(1, 1000, default=1)
    """Rollouts that share one road, each on its own ego (`RolloutTask`); 1: one rollout per simulation, as the
    paper."""
    rollout_decisions: int | None = bounded(1, 100_000, default=None, integer=True)
    """None: a rollout drives `episodes_per_rollout` whole episodes (the paper's). D: a rollout is D decisions of
    its ego, respawning whenever an episode ends, so the egos of a road never wait for each other; its return is
    the mean reward per decision."""
    flip_rate: float | None = bounded(0, 1, default=None, low_open=True, high_open=True)
    """When set, nu is chosen at every iteration so that the iteration's perturbations change this share of the
    policy's decisions on CALIBRATION_STATES of the expert's states (`noise.noise_for_flip_rate`), in place of the
    paper's nu schedule (`noise`)."""
    roads: tuple[str, ...] = given("--roads", ())
    """Roads (scenario kinds) the directions take in turn, direction k's rollouts on roads[k mod len]: RAIL on a mix
    of roads (`runners.road_mix`). Empty: every rollout on the configured road."""
    rollout_seats: int = bounded(0, 1000, default=0)
    """0: rollouts on the generated road (the paper's). S: on demonstrations read from a recorded scene, each rollout
    drives S train-split seats of that scene, one episode of env.max_episode_s each, the others replayed; both signs
    of a direction the same seats (`seat_rollouts`); its return is their mean."""
    seat_lead_s: float = bounded(0, 600, "s", default=5.0)
    """With rollout_seats: the ego takes a seat this long after the car's track begins (evaluate-scene's --lead-s)."""
    seat_zone_m: float = bounded(0, 100_000, "m", default=0.0)
    """With rollout_seats: seats where traffic is established (evaluate-scene's --zone-m)."""

    def __post_init__(self) -> None:
        check_fields(self, "rail.")
        if self.kept > self.directions:
            raise ValueError(f"rail.top must be between 1 and rail.directions ({self.directions}), got {self.top}")
        if self.fitness not in FITNESS_SHAPINGS:
            raise ValueError(f"rail.fitness must be one of {', '.join(FITNESS_SHAPINGS)}, got {self.fitness!r}")
        if self.rollout_decisions is not None and self.episodes_per_rollout > 1:
            raise ValueError(f"rail.rollout_decisions replaces rail.episodes_per_rollout, got "
                             f"{self.rollout_decisions} with {self.episodes_per_rollout} episodes per rollout")
        if self.reward not in REWARDS:
            raise ValueError(f"rail.reward must be one of {', '.join(REWARDS)}, got {self.reward!r}")
        if self.rollout_seats and (self.egos > 1 or self.rollout_decisions or self.episodes_per_rollout > 1
                                   or self.roads):
            raise ValueError("rail.rollout_seats drives each rollout in its own seats, one ego and episode each, so "
                             "it takes no rail.egos, rail.rollout_decisions, rail.episodes_per_rollout or --roads")

    @property
    def kept(self) -> int:
        """b as used: `top`, or N / 2 rounded up."""
        return self.top if self.top is not None else (self.directions + 1) // 2


@dataclass(frozen=True)
class Trajectory:
    """What a rollout sends back: the pairs the discriminator scores."""

    observations: np.ndarray
    """Shape (T, n) float32."""
    actions: np.ndarray
    """Shape (T,) int64."""
    collided: bool
    steps: int
    expert_actions: np.ndarray | None = None
    """Shape (T,) int64: what the expert would have done at each decision (when the task asked it), else None."""


@dataclass(frozen=True)
class Perturbations:
    """theta and the integers that name its perturbations theta + sign * nu * delta(iteration, index): what crosses
    the process boundary for a rollout (never a direction vector)."""

    config: Config
    shape: PolicyShape
    parameters: np.ndarray
    observation_mean: np.ndarray
    observation_std: np.ndarray
    noise_seed: int
    iteration: int

    def perturbed(self, index: int, sign: int, nu: float) -> Policy:
        """theta + sign * nu * delta(iteration, index), with theta's observation statistics."""
        delta = direction(self.noise_seed, self.iteration, index, self.shape.parameter_count)
        return Policy(self.shape, self.parameters + np.float32(sign * nu) * delta, self.observation_mean,
                      self.observation_std)


@dataclass(frozen=True)
class RolloutTask(Perturbations):
    """Rollouts of one iteration on one road: member j, (index, sign), drives ego_j of a `ParallelHighwayEnv` with
    theta + sign * nu * delta(iteration, index); the other members are traffic to it (one member: the paper's
    rollout on its own simulation, bit for bit the single-ego env's)."""

    members: tuple[tuple[int, int], ...]
    nu: float
    episode_seeds: tuple[int, ...]
    expert: DriverSpec | None = None
    """Asked at every decision what it would do (it never drives); its answers come back as `expert_actions`."""
    decisions: int | None = None
    """None: every member drives one whole episode per episode seed (the egos of the road wait for the last one).
    D: every member drives D decisions on the road seeded by episode_seeds[0], respawning whenever its episode ends
    (`rollout.drive_egos`), so none waits."""

    def run(self, context: WorkerContext) -> list[list[Trajectory]]:
        """Per member, one trajectory per episode (with no decision where its ego found no room) or, with
        `decisions`, per life."""
        policies = [self.perturbed(index, sign, self.nu) for index, sign in self.members]
        env = context.parallel_env(self.config, len(self.members))
        trajectories: list[list[Trajectory]] = [[] for _ in self.members]
        for seed in self.episode_seeds[:1] if self.decisions is not None else self.episode_seeds:
            labels: list[list[int]] = [[] for _ in policies]
            drivers = [asking(policy, None if self.expert is None else self.expert.create(self.config, seed), asked)
                       for policy, asked in zip(policies, labels, strict=True)]
            results: Sequence[Sequence[EpisodeResult | None]] = (
                [[result] for result in run_shared_episode(env, drivers, seed, record=True)]
                if self.decisions is None else drive_egos(env, drivers, seed, self.decisions, record=True))
            for member, (lives, asked) in enumerate(zip(results, labels, strict=True)):
                trajectories[member].extend(trajectories_of(lives, asked if self.expert is not None else None,
                                                             env.observation_space(env.possible_agents[0]).shape[0]))
        return trajectories


def trajectories_of(lives: Sequence[EpisodeResult | None], labels: list[int] | None, size: int) -> list[Trajectory]:
    """One ego's episodes as trajectories (an ego that found no room: none of its decisions), `labels` the expert's
    answers at all of them in order."""
    trajectories, done = [], 0
    for result in lives:
        observations, actions = ((result.steps["observation"], result.steps["action"].astype(np.int64))
                                 if result is not None and result.steps is not None
                                 else (np.zeros((0, size), np.float32), np.zeros(0, np.int64)))
        trajectories.append(Trajectory(observations, actions, bool(result and result.metrics["collisions"]),
                                       len(actions), None if labels is None
                                       else np.array(labels[done:done + len(actions)], np.int64)))
        done += len(actions)
    return trajectories


def asking(policy: Policy, expert: Driver | None, labels: list[int]) -> Driver:
    """The policy as a driver that, when `expert` is given, first appends the expert's action to `labels`."""
    if expert is None:
        return lambda observation, traffic: policy.act(observation)

    def drive(observation: np.ndarray, traffic: TrafficView) -> int:
        labels.append(expert(observation, traffic))
        return policy.act(observation)
    return drive


class SeatRollouts(Protocol):
    """An iteration's 2N rollouts elsewhere than on the generated road, in `run_rollouts`' order
    (`seat_rollouts.InSeats`: a recorded scene's seats)."""

    def __call__(self, policy: Policy, settings: RailSettings, iteration: int, nu: float, expert: DriverSpec | None,
                 backend: RolloutBackend, on_rollout: Callable[[int, Any], None] | None) -> list[list[Trajectory]]: ...


@dataclass
class TrainingState:
    """Everything that determines the rest of a run; a checkpoint stores exactly this."""

    iteration: int
    parameters: np.ndarray
    stats: RunningStats
    nu: float
    best_return: float
    best_at_last_check: float
    rng: np.random.Generator
    """Draws each iteration's episode seeds."""

    @classmethod
    def start(cls, parameters: np.ndarray, stats: RunningStats, settings: RailSettings) -> TrainingState:
        return cls(0, parameters.astype(np.float32), stats, settings.noise.initial, -np.inf, -np.inf,
                   np.random.default_rng(settings.seed))


@dataclass(frozen=True)
class IterationLog:
    """One row of the training log."""

    iteration: int
    env_steps: int
    return_mean: float
    return_max: float
    return_std: float
    nu: float
    reward_std: float
    discriminator_loss: float
    discriminator_accuracy: float
    collisions: int


CALIBRATION_STATES = 2000
"""Expert states on which `RailSettings.flip_rate` is measured (evenly spaced through the demonstrations)."""


def calibration_states(observations: np.ndarray) -> np.ndarray:
    """Up to CALIBRATION_STATES rows of `observations`, evenly spaced, in order."""
    rows = np.linspace(0, len(observations) - 1, min(CALIBRATION_STATES, len(observations))).round().astype(int)
    return np.asarray(observations)[rows]


def rollout_return(rewards: np.ndarray, collided: bool, horizon: int, lowest_reward: float) -> float:
    """Mean reward per decision; a collision's missing decisions up to `horizon` count at `lowest_reward`."""
    if collided and len(rewards) < horizon:
        return float((rewards.sum() + (horizon - len(rewards)) * lowest_reward) / horizon)
    return float(rewards.mean())


def run_rollouts(policy: Policy, config: Config, noise_seed: int, iteration: int, nu: float,
                 seeds: list[tuple[int, ...]], expert: DriverSpec | None, egos: int, backend: RolloutBackend,
                 on_rollout: Callable[[int, Any], None] | None = None,
                 decisions: int | None = None, roads: Sequence[Config] = ()) -> list[list[Trajectory]]:
    """The 2N rollouts of theta +- nu delta_k (k < len(seeds), direction k on its episode `seeds[k]`), in the order
    (0, +), (0, -), (1, +), ...: `egos` consecutive rollouts per simulation, sharing the episode seeds and the road of
    the first one's direction (`RolloutTask`; `decisions`: its budget of decisions per rollout; `roads`: the configs
    direction k takes in turn, roads[k mod len], else `config`); `on_rollout(index, rollouts)` as each simulation's
    rollouts arrive."""
    members = [(k, sign) for k in range(len(seeds)) for sign in (1, -1)]
    configs = list(roads) or [config]
    fields = (policy.shape, policy.parameters, policy.observation_mean, policy.observation_std, noise_seed, iteration)
    shared = backend.run([RolloutTask(configs[group[0][0] % len(configs)], *fields, group, nu, seeds[group[0][0]],
                                      expert, decisions)
                          for group in shared_groups(members, egos)], on_result=on_rollout)
    return [rollout for group in shared for rollout in group]


def _returns(rollouts: list[list[Trajectory]], score: Callable[[Trajectory], float], horizon: int,
             per_decision: bool) -> np.ndarray:
    """Each rollout's score: the mean over its episodes with decisions or, `per_decision` (lives of a budget of
    decisions), their mean weighted by decisions (a collision's up to `horizon`: `rollout_return`'s mean per
    decision over all of them); a rollout with none (its ego never found room on the road, which only several egos
    per simulation can cause) gets the mean of the others, no signal either way."""
    def value(rollout: list[Trajectory]) -> float:
        lives = [t for t in rollout if t.steps > 0]
        if not lives:
            return np.nan
        if not per_decision:
            return float(np.mean([score(t) for t in lives]))
        weights = [horizon if t.collided and t.steps < horizon else t.steps for t in lives]
        return float(np.average([score(t) for t in lives], weights=weights))
    returns = np.array([value(rollout) for rollout in rollouts])
    return np.where(np.isnan(returns), np.nanmean(returns), returns)


def discriminator_returns(rollouts: list[list[Trajectory]], discriminator: Discriminator, horizon: int,
                          per_decision: bool = False) -> np.ndarray:
    """Each rollout's return, shape (rollouts,): `_returns` of `rollout_return` of the discriminator's rewards."""
    lowest = discriminator.lowest_reward()
    return _returns(rollouts, lambda t: rollout_return(discriminator.reward(t.observations, t.actions), t.collided,
                                                       horizon, lowest), horizon, per_decision)


def agreement_returns(rollouts: list[list[Trajectory]], horizon: int, per_decision: bool = False) -> np.ndarray:
    """Each rollout's agreement with the expert, shape (rollouts,): `_returns` of `rollout_return` of 1 where the
    expert would have chosen the action taken, else 0 (a collision's missing decisions count as 0)."""
    return _returns(rollouts, lambda t: rollout_return((t.actions == t.expert_actions).astype(np.float64),
                                                       t.collided, horizon, 0.0), horizon, per_decision)


def run_iteration(state: TrainingState, shape: PolicyShape, config: Config, settings: RailSettings,
                  discriminator: Discriminator, expert: Demonstrations, backend: RolloutBackend,
                  on_rollout: Callable[[int, Any], None] | None = None,
                  asked: DriverSpec | None = None, in_seats: SeatRollouts | None = None) -> IterationLog:
    """Advance `state` by one iteration in place and return its log row; `asked`: the expert the agreement reward
    asks (the demonstrations' rule-based expert when not given); `in_seats`: the rollouts run there (recorded seats)
    rather than on the generated road."""
    n, per_rollout, noise_seed = settings.directions, settings.episodes_per_rollout, settings.seed
    mean, std = state.stats.mean.copy(), state.stats.std.copy()
    deltas = directions(noise_seed, state.iteration, n, shape.parameter_count)
    if settings.flip_rate is not None:
        state.nu = noise_for_flip_rate(Policy(shape, state.parameters, mean, std), deltas, settings.flip_rate,
                                       calibration_states(expert.observations))
    if settings.reward != "agreement":
        asked = None
    elif asked is None:
        asked = ExpertDriver(expert.metadata.get("style") or DEFAULT_STYLE)
    policy = Policy(shape, state.parameters, mean, std)
    if in_seats is not None:
        rollouts = in_seats(policy, settings, state.iteration, state.nu, asked, backend, on_rollout)
    else:
        sets = 1 if settings.common_traffic else n
        drawn = [episode_seeds(Purpose.TRAIN, int(state.rng.integers(2**31)), 1)[0] for _ in range(sets * per_rollout)]
        seeds = [tuple(drawn[(0 if settings.common_traffic else k) * per_rollout:][:per_rollout]) for k in range(n)]
        rollouts = run_rollouts(policy, config, noise_seed, state.iteration, state.nu, seeds, asked, settings.egos,
                                backend, on_rollout, settings.rollout_decisions, road_configs(config, settings.roads))
    trajectories = [trajectory for rollout in rollouts for trajectory in rollout]
    policy_observations = np.concatenate([t.observations for t in trajectories])
    policy_actions = np.concatenate([t.actions for t in trajectories])
    report = discriminator.train(expert.observations, expert.actions, policy_observations, policy_actions)
    horizon = round(config.env.max_episode_s / config.env.decision_period_s)
    per_decision = settings.rollout_decisions is not None
    returns = (agreement_returns(rollouts, horizon, per_decision) if settings.reward == "agreement"
               else discriminator_returns(rollouts, discriminator, horizon, per_decision))
    step = ars_update(state.parameters, deltas, returns[0::2], returns[1::2], settings.kept, settings.step_size,
                      settings.fitness)
    if not settings.freeze_normalizer:
        for trajectory in trajectories:
            state.stats = state.stats.merge(RunningStats.of(trajectory.observations))
    state.parameters = step.parameters
    log = IterationLog(state.iteration, int(sum(t.steps for t in trajectories)), float(returns.mean()),
                       float(returns.max()), float(returns.std()), state.nu, step.reward_std, report.loss,
                       report.accuracy, int(sum(t.collided for t in trajectories)))
    state.best_return = max(state.best_return, log.return_mean)
    if settings.flip_rate is None:
        state.nu = adapt_noise(state.nu, state.iteration, state.best_at_last_check, state.best_return, settings.noise)
    if (state.iteration + 1) % settings.noise.every == 0:
        state.best_at_last_check = state.best_return
    state.iteration += 1
    return log
