"""Egos that never stop: the one respawn loop of the rollout runner's lives (`sumo_rail.runners.rollout.drive_egos` with
a budget of decisions) and of the learners' respawning roads (`sumo_rail.learning.sb3.shared_road`).

`RespawningEgos` drives every ego of a `ParallelHighwayEnv` at every step: an ego whose episode ends respawns at once
(`ParallelHighwayEnv.respawn`) while the others drive on. When the egos jam the road's start so that one finds no
place to respawn, every episode still going is cut there (a truncation) and the road resets. With
`reset_when_empty`, a step that ends every ego's episode resets the road instead of respawning them (with one ego:
a reset after each episode, as a single-ego env's). With `respawn` False an ego whose episode ends leaves the road
and the road is never reset: one whole episode each, the same steps (`drive_egos` without a budget).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sumo_rail.sim.parallel_env import Infos, NoRoomToRespawn, Observations, ParallelHighwayEnv
from sumo_rail.sim.rewards import EpisodeMetrics


@dataclass(frozen=True)
class RespawnStep:
    """One decision of every ego: the env's step, the episodes it ended, and where each ego's next decision starts."""

    observations: Observations
    """The step's (an ended episode's last)."""
    rewards: dict[str, float]
    terminations: dict[str, bool]
    truncations: dict[str, bool]
    infos: Infos
    """The step's."""
    metrics: dict[str, EpisodeMetrics]
    """Each ego's totals of the episode it drove in this step."""
    ended: tuple[str, ...]
    """The egos whose episode ended at this step (terminated, truncated or cut by a jam), in agent order."""
    cut: tuple[str, ...]
    """The egos whose episode a jam cut (the step itself ended it not)."""
    next_observations: Observations
    """What each ego decides on next: the step's, or its new episode's first."""
    next_infos: Infos

    def truncated(self, agent: str) -> bool:
        """Whether `agent`'s episode was truncated at this step, by the step or by a jam."""
        return self.truncations[agent] or agent in self.cut


class RespawningEgos:
    """The egos of `env`, each respawning as soon as its episode ends, unless `respawn` is False (see the module's
    docstring); the road's first reset is seeded with `seed`, later ones draw on from its generator; every reset
    takes `options` (the env's reset options)."""

    def __init__(self, env: ParallelHighwayEnv, seed: int | None, reset_when_empty: bool,
                 respawn: bool = True, options: dict[str, Any] | None = None) -> None:
        self.env = env
        self.seed = seed
        """Seed of the next reset: the first one's, then None (later resets draw on from the road's generator)."""
        self.reset_when_empty = reset_when_empty
        self.respawn = respawn
        self.options = options

    def start(self) -> tuple[Observations, Infos]:
        """Reset the road (the first time with `seed`); an ego that could not enter respawns. Every ego's first
        observation and info."""
        observations, infos = self.env.reset(seed=self.seed, options=self.options)
        self.seed = None
        for agent in self.env.possible_agents if self.respawn else ():
            if agent not in observations:
                observations[agent], infos[agent] = self.env.respawn(agent)
        return observations, infos

    def step(self, actions: dict[str, int]) -> RespawnStep:
        """One decision of every ego (`actions` has each ego's); each whose episode ended respawns, or the road
        resets (a jam, or with `reset_when_empty` no ego left on it)."""
        env = self.env
        observations, rewards, terminations, truncations, infos = env.step(actions)
        metrics = {agent: env.metrics(agent) for agent in env.possible_agents}
        ended = [agent for agent in env.possible_agents if terminations.get(agent) or truncations.get(agent)]
        next_observations, next_infos = dict(observations), dict(infos)
        jammed = False
        if self.respawn and (env.agents or not self.reset_when_empty):
            try:
                for agent in ended:
                    next_observations[agent], next_infos[agent] = env.respawn(agent)
            except NoRoomToRespawn:  # the egos jam the road's start (a ramp): every episode is cut
                jammed = True
        cut = tuple(agent for agent in env.possible_agents if jammed and agent not in ended)
        if self.respawn and (jammed or not env.agents):
            next_observations, next_infos = self.start()
        return RespawnStep(observations, rewards, terminations, truncations, infos, metrics,
                           tuple(agent for agent in env.possible_agents if agent in ended or agent in cut), cut,
                           next_observations, next_infos)
