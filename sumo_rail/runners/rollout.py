"""Drivers and episodes: `run_episode(env, driver, seed)` is a pure function of its inputs.

A driver maps (observation, traffic view) to an action. Drivers cross process boundaries as small picklable
recipes (`DriverSpec`) and are built per episode, so a driver's randomness comes from the episode's seed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from sumo_rail.config import Config
from sumo_rail.drivers.expert import DEFAULT_STYLE, make_expert
from sumo_rail.drivers.policies import Policy
from sumo_rail.runners.dart import ActionNoise
from sumo_rail.seeding import driver_generator
from sumo_rail.sim.actions import Action, action_count, keep_action
from sumo_rail.sim.controllers import ActionController, SumoController
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv
from sumo_rail.sim.respawning import RespawningEgos
from sumo_rail.sim.rewards import EpisodeMetrics
from sumo_rail.sim.traffic import TrafficView

if TYPE_CHECKING:
    from sumo_rail.runners.backends import WorkerContext

T = TypeVar("T")
Driver = Callable[[np.ndarray, TrafficView], int]
ACTION_COLUMNS = tuple(f"action_{action.name.lower()}" for action in Action)
"""Metrics columns counting each action, in action order."""


class DriverSpec(Protocol):
    """A picklable recipe for a driver."""

    @property
    def name(self) -> str: ...

    def create(self, config: Config, seed: int) -> Driver: ...


@dataclass(frozen=True)
class KeepDriver:
    """Never acts: keeps its lane and set-point (under the acceleration interface: its lane and speed, an
    acceleration of 0, the constant-speed baseline)."""

    name: str = "keep"

    def create(self, config: Config, seed: int) -> Driver:
        keep = keep_action(config.actions)
        return lambda observation, traffic: keep


@dataclass(frozen=True)
class SumoIdmDriver:
    """SUMO's IDM and LC2013 in the ego's seat: asks the env core for its "sumo" controller
    (`sumo_rail.sim.controllers.SumoController`, a recorded scene's); the actions (keep's) are counted, not used."""

    name: str = "sumo-idm"
    controller: str = SumoController.name

    def create(self, config: Config, seed: int) -> Driver:
        return KeepDriver().create(config, seed)


def controller_of(driver: DriverSpec) -> str:
    """The env core's controller `driver` asks for (reset option "controller"): its own `controller`, else the env's
    actions."""
    return str(getattr(driver, "controller", ActionController.name))


@dataclass(frozen=True)
class RandomDriver:
    """Uniformly random actions, seeded by the episode's seed."""

    name: str = "random"

    def create(self, config: Config, seed: int) -> Driver:
        rng, count = np.random.default_rng(seed), action_count(config.actions)
        return lambda observation, traffic: int(rng.integers(count))


@dataclass(frozen=True)
class ExpertDriver:
    """The rule-based expert of one style."""

    style: str = DEFAULT_STYLE

    @property
    def name(self) -> str:
        return f"expert-{self.style}"

    def create(self, config: Config, seed: int) -> Driver:
        return make_expert(self.style, config.env.speed_step_mps, config.expert.view_range_m)


@dataclass(frozen=True)
class PolicyDriver:
    """A learned policy: its logits on the observation read by its decoding (`Policy.act`: their argmax unless
    actions.decoding says otherwise), or with `sampled` an action drawn from their softmax at `temperature` by the
    episode's `driver_generator`."""

    policy: Policy
    name: str
    expert: str | None = None
    """The expert whose demonstrations trained the policy (a style or a policy file), when its file records it."""
    sampled: bool = False
    temperature: float = 1.0
    """The sampling temperature (`actions.sampling_temperature`) of a sampled driver."""

    def create(self, config: Config, seed: int) -> Driver:
        if self.sampled:
            sample, rng, temperature = self.policy.sample, driver_generator(seed), self.temperature
            return lambda observation, traffic: sample(observation, rng, temperature)
        act = self.policy.act
        return lambda observation, traffic: act(observation)


@dataclass
class EpisodeResult:
    """One episode: its metrics row and, when recorded, one entry per decision in each step column."""

    metrics: dict[str, Any]
    steps: dict[str, np.ndarray] | None


def shared_groups(items: Sequence[T], egos: int) -> list[tuple[T, ...]]:
    """`items` (episode seeds, rollouts) in consecutive groups of `egos`, the last one possibly smaller: what shares
    one simulation."""
    return [tuple(items[start:start + egos]) for start in range(0, len(items), egos)]


@dataclass(frozen=True)
class EpisodeGroupTask:
    """Episodes of one driver in one simulation, one per ego (the unit of work of the runners; one seed: the
    single ego's episode, bit for bit `run_episode`'s on `HighwayEnv`): ego j drives the driver seeded by seeds[j],
    the simulation is seeded by seeds[0]; the other egos are traffic to it."""

    config: Config
    driver: DriverSpec
    seeds: tuple[int, ...]
    record: bool = False
    noise: ActionNoise | None = None
    """Noise on each ego's executed actions (DART, drawn from its own seed's stream); the records keep the driver's."""

    def run(self, context: WorkerContext) -> list[EpisodeResult | None]:
        """Each ego's episode (its metrics' seed: its own seed), in ego order; None for an ego that found no room."""
        drivers = [self.driver.create(self.config, seed) for seed in self.seeds]
        count = action_count(self.config.actions)
        perturbs = None if self.noise is None else [self.noise.perturbation(seed, count) for seed in self.seeds]
        results = run_shared_episode(context.parallel_env(self.config, len(self.seeds)), drivers, self.seeds[0],
                                     self.record, perturbs)
        return [None if result is None else EpisodeResult({**result.metrics, "seed": seed}, result.steps)
                for result, seed in zip(results, self.seeds, strict=True)]


def run_episode(env: HighwayEnv, driver: Driver, seed: int, record: bool = False,
                options: dict[str, Any] | None = None) -> EpisodeResult:
    """Reset with `seed` (and the env's reset `options`) and drive until the episode ends; `record` keeps every
    (state, action, reward). The one ego's episode of `run_shared_episode`, on the Gymnasium env's core (its reset
    seeded as the Gymnasium env's own; what watches it watches the env: `HighwayEnv.watching`)."""
    episode = run_shared_episode(env.core, [driver], seed, record, options=options)[0]
    assert episode is not None  # HighwayEnv always places its ego (or raises)
    return episode


def run_shared_episode(env: ParallelHighwayEnv, drivers: Sequence[Driver], seed: int, record: bool = False,
                       perturbs: Sequence[Callable[[int], int]] | None = None,
                       options: dict[str, Any] | None = None) -> list[EpisodeResult | None]:
    """Reset `env` with `seed` (and reset `options`) and drive ego_j with drivers[j] until every ego has left
    (`drive_egos` without a budget): each ego's episode (its metrics' seed is `seed`), in ego order, None for an ego
    that found no room on the road."""
    return [lives[0] if lives else None
            for lives in drive_egos(env, drivers, seed, None, record, perturbs, options)]


def drive_egos(env: ParallelHighwayEnv, drivers: Sequence[Driver], seed: int, decisions: int | None = None,
               record: bool = False, perturbs: Sequence[Callable[[int], int]] | None = None,
               options: dict[str, Any] | None = None) -> list[list[EpisodeResult]]:
    """The one episode loop. Reset `env` with `seed` and drive ego_j with drivers[j] (asked in ego order at each
    decision): with `decisions` None, one whole episode each (an ego leaves when its episode ends; one that found no
    room has none); with a number, that many decisions each across as many lives as it takes (an ego whose episode
    ends, or that found no room, respawns at once: `sumo_rail.sim.respawning.RespawningEgos`; when the egos jam the
    road's start, every life is cut there, a truncation, and the road resets), the last life, cut by the budget,
    neither terminated nor truncated. Each ego's episodes in order (metrics' seed `seed`). With `perturbs` ego_j's
    car executes perturbs[j](action) while the records keep the driver's (DART); every reset takes `options`. What
    watches the egos' decisions watches `env` (`ParallelHighwayEnv.watching`, `sumo_rail.sim.observers`)."""
    road = RespawningEgos(env, seed, reset_when_empty=False, respawn=decisions is not None, options=options)
    observations, infos = road.start()
    agents = list(env.possible_agents)
    logs = {agent: _EpisodeLog(record) for agent in agents}
    lives: dict[str, list[EpisodeResult]] = {agent: [] for agent in agents}
    done = 0
    while env.agents and (decisions is None or done < decisions):
        actions = {agent: int(drivers[agents.index(agent)](observations[agent], env.traffic(agent)))
                   for agent in env.agents}
        executed = actions if perturbs is None else \
            {agent: perturbs[agents.index(agent)](action) for agent, action in actions.items()}
        step = road.step(executed)
        for agent, action in actions.items():
            logs[agent].add(observations[agent], action, step.rewards[agent], infos[agent], step.infos[agent])
        for agent in step.ended:
            lives[agent].append(logs[agent].result(step.metrics[agent], seed, step.infos[agent],
                                                   step.terminations[agent], step.truncated(agent)))
            logs[agent] = _EpisodeLog(record)
        observations, infos = step.next_observations, step.next_infos
        done += 1
    return [[*lives[agent], *([logs[agent].result(env.metrics(agent), seed, infos[agent], False, False)]
                              if logs[agent].decisions else [])] for agent in agents]


class _EpisodeLog:
    """One ego's episode: with `record`, every decision's (observation, state, action, reward) for the step
    columns; the metrics row at its end either way."""

    def __init__(self, record: bool) -> None:
        self.record = record
        self.decisions = 0
        self.observations: list[np.ndarray] = []
        self.rows: list[tuple[Any, ...]] = []

    def add(self, observation: np.ndarray, action: int, reward: float, before: dict[str, Any],
            info: dict[str, Any]) -> None:
        """A decision: `before` is the info the driver decided on, `info` the step's."""
        self.decisions += 1
        if self.record:
            self.observations.append(observation)
            self.rows.append((action, reward, info["reward_longitudinal"], info["reward_lateral"],
                              info["reward_collision"], before["speed_mps"], before["lane"], before["position_m"],
                              before["set_point_mps"], info["lane_change_in_progress"]))

    def result(self, m: EpisodeMetrics, seed: int, info: dict[str, Any], terminated: bool,
               truncated: bool) -> EpisodeResult:
        metrics: dict[str, Any] = {
            "seed": seed, "steps": m.decisions, "simulated_s": m.simulated_s, "distance_m": m.distance_m,
            "average_speed_kmh": m.average_speed_mps * 3.6, "overtakes": m.overtakes, "overtaken": m.overtaken,
            "lane_changes": m.lane_changes, "longitudinal_reward": m.longitudinal_reward,
            "lateral_reward": m.lateral_reward, "collisions": m.collisions, "hard_braking": m.hard_braking,
            "teleports": m.teleports, "invalid_actions": m.invalid_actions, "merges": m.merges,
            "merge_time_s": m.merge_time_s, "missed_exits": m.missed_exits, "lane_end_stops": m.lane_end_stops,
            **dict(zip(ACTION_COLUMNS, m.action_counts, strict=True)),
            "termination": info["termination"], "terminated": terminated, "truncated": truncated,
        }
        return EpisodeResult(metrics, _step_columns(self.observations, self.rows) if self.record else None)


_STEP_FIELDS = ("action", "reward", "reward_longitudinal", "reward_lateral", "reward_collision", "speed_mps",
                "lane", "position_m", "set_point_mps", "lane_change_in_progress")


def _step_columns(observations: list[np.ndarray], rows: list[tuple[Any, ...]]) -> dict[str, np.ndarray]:
    columns = {name: np.array(values) for name, values in zip(_STEP_FIELDS, zip(*rows, strict=True), strict=True)}
    columns["observation"] = np.stack(observations).astype(np.float32)
    return columns


@dataclass(frozen=True)
class EpisodeTask:
    """One episode of the single-ego `HighwayEnv` (evaluation runs `sumo_rail.evaluation.protocol.EvaluationTask`s;
    recordings and learners `EpisodeGroupTask`s)."""

    config: Config
    driver: DriverSpec
    seed: int
    record: bool = False
    pool: str = "train"
    """Warm-state pool the episode starts from ("train", "validation" or "test")."""
    warm_state: int | None = None
    """Index of the warm state in the pool; None: drawn from the seed."""

    def run(self, context: WorkerContext) -> EpisodeResult:
        """Run the episode on the context's env."""
        env = context.env(self.config)
        options: dict[str, Any] = {"pool": self.pool}
        if self.warm_state is not None:
            options["warm_state"] = self.warm_state
        return run_episode(env, self.driver.create(self.config, self.seed), self.seed, self.record, options)
