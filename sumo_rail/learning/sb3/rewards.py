"""The rewards PPO sees in GAIL: the environments run in spawned processes (libsumo: one simulation per process,
`envs`); `labelled_vec_env` puts a `vec_envs.NormalisedVecEnv` in front of them, which keeps the raw (observation,
action) pairs, replaces the env's reward with log D - log(1 - D) of the current discriminator (`RewardLabeller`; pairs
are scored as they come, by the discriminator of the previous updates) and normalises the observations PPO sees by
fixed statistics. A collision adds (horizon - decisions so far) x the lowest reward to its final step, so ending
early never pays.

Reward normalisation (`normalised_rewards`, on by default in `GailSettings`): Stable-Baselines3's VecNormalize for
rewards only divides each reward by the running std of the discounted return and clips it to +-REWARD_CLIP. A
collision's padding is up to (horizon - 1) x the lowest reward (about -6.9 nats x 599 at the defaults), thousands
of times a decision's reward; unscaled, its value targets dominate the critic's squared loss and, through the
advantages, PPO's step, so one crash outweighs every decision's imitation signal. RAIL's ARS divides its step by
the std of its returns (sigma_R), so this gives PPO the analogous scaling (its standard practice), not an advantage
over RAIL. The observations keep their fixed normalisation (a running one would move under the BC-initialised
actor). Stable-Baselines3 is imported only by the functions that need it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from sumo_rail.learning.rail.discriminator import Discriminator
from sumo_rail.learning.rail.iteration import rollout_return
from sumo_rail.learning.sb3.actor import FixedNormalisation

if TYPE_CHECKING:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecEnv

REWARD_CLIP = 10.0
"""Bound on PPO's normalised rewards (Stable-Baselines3's VecNormalize default)."""


@dataclass(frozen=True)
class Rollout:
    """The pairs and discriminator returns of one PPO rollout."""

    observations: np.ndarray
    """Raw observations, shape (T x envs, n) float32."""
    actions: np.ndarray
    """Shape (T x envs,) int64."""
    rewards: np.ndarray
    """Discriminator reward of each pair, before any collision padding, shape (T x envs,) [nats]."""
    returns: np.ndarray
    """Per-decision return (`iteration.rollout_return`) of each episode that ended in the rollout."""
    collisions: int


class RewardLabeller:
    """Scores each env's (raw observation, action) with the discriminator, pads collisions and collects rollouts."""

    def __init__(self, discriminator: Discriminator, envs: int, horizon: int) -> None:
        self.discriminator, self.horizon = discriminator, horizon
        self.lowest_reward = discriminator.lowest_reward()
        self._episodes: list[list[float]] = [[] for _ in range(envs)]
        self._observations: list[np.ndarray] = []
        self._actions: list[np.ndarray] = []
        self._rewards: list[np.ndarray] = []
        self._returns: list[float] = []
        self._collisions = 0

    def label(self, observations: np.ndarray, actions: np.ndarray, dones: np.ndarray,
              infos: list[dict[str, Any]]) -> np.ndarray:
        """PPO's rewards (envs,) float32 for the actions taken on `observations`; `dones`/`infos` of that step."""
        observations, actions = np.asarray(observations, dtype=np.float32), np.asarray(actions, dtype=np.int64)
        rewards = self.discriminator.reward(observations, actions)
        self._observations.append(observations.copy())
        self._actions.append(actions.copy())
        self._rewards.append(rewards)
        padded = rewards.copy()
        for env, (reward, done, info) in enumerate(zip(rewards, dones, infos, strict=True)):
            episode = self._episodes[env]
            episode.append(float(reward))
            if done:
                collided = info.get("termination") == "collision"
                self._returns.append(rollout_return(np.array(episode), collided, self.horizon, self.lowest_reward))
                if collided:
                    self._collisions += 1
                    padded[env] += max(self.horizon - len(episode), 0) * self.lowest_reward
                episode.clear()
        return padded.astype(np.float32)

    def take(self) -> Rollout:
        """The pairs labelled since the last call (episodes still running carry on)."""
        rollout = Rollout(np.concatenate(self._observations), np.concatenate(self._actions),
                          np.concatenate(self._rewards), np.array(self._returns), self._collisions)
        self._observations, self._actions, self._rewards, self._returns, self._collisions = [], [], [], [], 0
        return rollout


def labelled_vec_env(venv: VecEnv, labeller: RewardLabeller, normalisation: FixedNormalisation) -> VecEnv:
    """The driving envs `venv` (`shared_road.driving_processes`) with the discriminator's rewards (`labeller`; the
    env's reward is dropped) and observations through `normalisation` (`vec_envs.NormalisedVecEnv`)."""
    from sumo_rail.learning.sb3.vec_envs import NormalisedVecEnv

    return NormalisedVecEnv(venv, normalisation, lambda raw, actions, rewards, dones, infos:
                            labeller.label(raw, actions, dones, infos))


def normalised_rewards(venv: VecEnv, gamma: float) -> VecEnv:
    """`venv` with each reward divided by the running std of the envs' discounted returns (discount `gamma`, reset
    at episode ends) and clipped to +-REWARD_CLIP: Stable-Baselines3's VecNormalize for rewards only (the
    observations are already normalised by fixed statistics and pass unchanged)."""
    from stable_baselines3.common.vec_env import VecNormalize

    return VecNormalize(venv, norm_obs=False, norm_reward=True, clip_reward=REWARD_CLIP, gamma=gamma)


def reward_std(model: PPO) -> float:
    """What PPO's rewards are divided by now: the running std of the discounted return (1 without normalisation)."""
    normaliser = model.get_vec_normalize_env()
    return 1.0 if normaliser is None else float(np.sqrt(normaliser.ret_rms.var + normaliser.epsilon))
