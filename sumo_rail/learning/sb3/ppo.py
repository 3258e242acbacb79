"""The paper's expert: a driving policy trained by PPO (Stable-Baselines3) on the environment's own reward.

The reward of a decision is the env's (`sumo_rail.sim.env`): the longitudinal reward (v - v_min) / (v_max - v_min)
in [0, 1], the lateral penalty while a lane change is under way and the collision penalty. Two documented shaping
options, 0 by default: `overtake_reward` for every vehicle the ego overtakes in the decision, and
`keep_right_reward` x (L - 1 - lane) / (L - 1) per decision for L lanes (all of it in the rightmost lane, none in
the leftmost), the keep-right rule the rule-based expert follows. As in `gail`, PPO's rewards are divided by the
running std of the discounted return and clipped (`normalize_reward`).

The actor is a `PolicyShape` (`actor.policy_kwargs`): by default the learners' own two-layer policy (10 tanh
units), so a learner of the default size can imitate it exactly; it acts on the raw observation, whose entries
the env already scales to [-1, 2] (`sumo_rail.sim.observation`), so the exported policy's statistics are mean 0,
std 1. With `init` (a policy file of the same shape and observation layout: a BC, DAgger or earlier PPO policy)
PPO starts from that policy, on its observation statistics, and its first `critic_warmup` updates train the
critic alone (`actor.set_actor_trainable`, as in GAIL): BC pre-training then RL fine-tuning. The critic is
`actor.CRITIC_LAYERS`.

Reproducible as `gail`: env k's first episode has the Purpose.TRAIN seed of episode k from base seed x envs; PPO
is seeded and torch runs on one thread, so the same settings give the same policy bit for bit (for the same
number of envs).

runs/NAME/ holds `run.json` (settings, config, provenance), `policy_latest.npz`, `log.parquet` and `checkpoint.pt`,
replaced together after every update. The log has one row per update: iteration, env_steps (the decisions the
envs returned in the update, counted as they come), episodes (ended in the
update), return_mean / _max / _std (the undiscounted episode return PPO trains on, the env's reward plus any
shaping, of those episodes; NaN when none ended), speed_kmh, overtakes, lane_changes, collisions (per ended
episode), entropy (nats), actor_frozen, reward_std and wall_time_s. SIGINT / SIGTERM stop after the current
update, and `resume` continues from the last complete one (`sb3.resume` says what it restores exactly and what not).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sumo_rail.bounds import ConfigError, bounded, given
from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy, PolicyShape
from sumo_rail.learning.run_folder import start_run_folder, stop_requests
from sumo_rail.learning.sb3.actor import FixedNormalisation, load_into_ppo, ppo_to_policy, set_actor_trainable
from sumo_rail.learning.sb3.driving_envs import driving_processes
from sumo_rail.learning.sb3.resume import learner_checkpoint, restore_learner, resume_run, resumed_env_seed
from sumo_rail.learning.sb3.rewards import normalised_rewards, reward_std
from sumo_rail.learning.sb3.runs import (
    PpoSchedule,
    build_ppo,
    env_processes,
    require_stable_baselines3,
    save_update,
)
from sumo_rail.learning.torch_threads import single_thread
from sumo_rail.runners.experts import parse_policy
from sumo_rail.runners.tables import provenance
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_space

if TYPE_CHECKING:
    from stable_baselines3.common.vec_env import VecEnv

INSTALL_HINT = "sumo-rail ppo needs Stable-Baselines3: pip install 'sumo-rail[baselines]'"
KMH_PER_MPS = 3.6


@dataclass(frozen=True)
class PpoSettings(PpoSchedule):
    """What defines a PPO driver run (stored in run.json)."""

    timesteps: int = given("--timesteps", 400_000, kw_only=True)
    ent_coef: float = bounded(0, 10, default=0.01)
    """PPO's entropy bonus: keeps lane changes tried until their worth is learnt."""
    overtake_reward: float = bounded(0, 100, default=0.0)
    """Shaping: reward per vehicle overtaken (0: the env's reward alone)."""
    keep_right_reward: float = bounded(0, 100, default=0.0)
    """Shaping: reward per decision in the rightmost lane, falling linearly to 0 in the leftmost."""
    init: str | None = given("--init", None)
    """Policy file the actor starts from (None: PPO's own random initialisation)."""
    critic_warmup: int = bounded(0, 100_000, default=0, kw_only=True)
    """With --init only: first updates with the actor frozen while the critic learns; they count in --timesteps
    (left unset with --init: 5)."""

    def __post_init__(self) -> None:
        self.check_schedule("ppo")

    def check_warmup(self) -> None:
        """ConfigError for a critic warm-up without a policy to start from (a setting and an option together, so
        checked when the run is made, not when the section is set)."""
        if self.critic_warmup and self.init is None:
            raise ConfigError("ppo.critic_warmup needs --init: a critic warm-up keeps an initial actor while the "
                              "critic learns, and without --init the actor is PPO's random one")

    def shape(self, config: Config) -> PolicyShape:
        """The actor's layout on `config`'s observation."""
        return PolicyShape(self.kind, observation_space(config).shape[0], self.hidden,
                           action_count(config.actions), config.actions.decoding)


@dataclass(frozen=True)
class PpoResult:
    updates: int
    timesteps: int
    interrupted: bool
    """Stopped by SIGINT / SIGTERM before the last update."""


class EpisodeTally:
    """The env's return (with the shaping) and the end-of-episode totals of every episode that ends."""

    def __init__(self, envs: int, overtake_reward: float, keep_right_reward: float = 0.0, lanes: int = 5) -> None:
        self.overtake_reward = overtake_reward
        self.keep_right_per_lane = keep_right_reward / max(lanes - 1, 1)
        self.keep_right_reward = keep_right_reward
        self._returns = np.zeros(envs)
        self._overtakes = np.zeros(envs, dtype=np.int64)
        self.ended: list[dict[str, float]] = []
        self.decisions = 0
        """Decisions seen since the last `take` (all envs)."""

    def shaped(self, rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]]) -> np.ndarray:
        """This step's rewards plus the shaping; records the episodes that ended."""
        overtakes = np.array([info["overtakes"] for info in infos], dtype=np.int64)
        lanes_left_of_rightmost = np.array([info["lane"] for info in infos], dtype=np.float64)
        rewards = (np.asarray(rewards, dtype=np.float64) + self.overtake_reward * (overtakes - self._overtakes)
                   + self.keep_right_reward - self.keep_right_per_lane * lanes_left_of_rightmost)
        self._returns += rewards
        self.decisions += len(rewards)
        for env in np.flatnonzero(dones):
            info = infos[env]
            self.ended.append({"return": float(self._returns[env]),
                               "speed_kmh": KMH_PER_MPS * info["distance_m"] / max(info["time_s"], 1e-9),
                               "overtakes": info["overtakes"], "lane_changes": info["lane_changes"],
                               "collisions": info["collisions"]})
        overtakes[dones] = 0
        self._returns[dones] = 0.0
        self._overtakes = overtakes
        return rewards.astype(np.float32)

    def take(self) -> list[dict[str, float]]:
        """The episodes that ended since the last call (and the decision count starts again)."""
        ended, self.ended, self.decisions = self.ended, [], 0
        return ended


def driving_vec_env(venv: VecEnv, tally: EpisodeTally, normalisation: FixedNormalisation) -> VecEnv:
    """The driving envs `venv` (`driving_envs.driving_processes`) with rewards through `tally` and observations
    through `normalisation` (`vec_envs.NormalisedVecEnv`)."""
    from sumo_rail.learning.sb3.vec_envs import NormalisedVecEnv

    return NormalisedVecEnv(venv, normalisation, lambda raw, actions, rewards, dones, infos:
                            tally.shaped(rewards, dones, infos))


def train_ppo_driver(folder: Path, settings: PpoSettings, config: Config,
                     on_update: Callable[[dict[str, Any]], None] | None = None, resume: bool = False) -> PpoResult:
    """Train into the empty or new `folder`, or with `resume` continue the run in it from its last complete update
    (`sb3.resume`); `on_update` gets each new log row once its update is saved."""
    require_stable_baselines3(INSTALL_HINT)
    settings.check_warmup()
    folder = Path(folder)
    shape = settings.shape(config)
    run_record = {"settings": settings.to_dict(), **provenance("ppo_run", config, settings.seed)}
    if resume:
        checkpoint = resume_run(folder, run_record)
        initial, normalisation, rows = None, checkpoint["normalisation"], checkpoint["log"]
    else:
        checkpoint, initial = None, None if settings.init is None else initial_policy(Path(settings.init), shape,
                                                                                       config)
        normalisation = (FixedNormalisation(np.zeros(shape.observation_size), np.ones(shape.observation_size))
                         if initial is None else FixedNormalisation(initial.observation_mean, initial.observation_std))
        start_run_folder(folder, run_record)
        rows = []
    done = len(rows)
    tally = EpisodeTally(settings.vec_envs, settings.overtake_reward, settings.keep_right_reward,
                         config.scenario.lanes)
    with single_thread(), env_processes(folder, "PPO", lambda: len(rows)) as processes:
        processes.venv = driving_vec_env(driving_processes(config, settings.envs, settings.egos,
                                                           resumed_env_seed(settings.seed, done),
                                                           processes.error_dir), tally, normalisation)
        if settings.normalize_reward:
            processes.venv = normalised_rewards(processes.venv, settings.gamma)
        model = build_ppo(processes.venv, shape, settings, ent_coef=settings.ent_coef)
        if initial is not None:
            load_into_ppo(initial, model.policy)
        if checkpoint is not None:
            restore_learner(model, checkpoint, folder / "checkpoint.pt")
        with stop_requests() as stop:
            for update in range(done, settings.updates):
                started = time.perf_counter()
                frozen = update < settings.critic_warmup
                set_actor_trainable(model.policy, not frozen)
                model.learn(settings.steps_per_update, reset_num_timesteps=False)
                row = {"iteration": update, "env_steps": tally.decisions, **_episode_summary(tally.take()),
                       "entropy": -float(model.logger.name_to_value["train/entropy_loss"]),
                       "actor_frozen": frozen, "reward_std": reward_std(model),
                       "wall_time_s": time.perf_counter() - started}
                save_update(folder, ppo_to_policy(model.policy, shape, normalisation), [*rows, row], run_record,
                            learner_checkpoint(model, normalisation, [*rows, row]))
                rows.append(row)
                if on_update is not None:
                    on_update(row)
                if stop.is_set():
                    break
        return PpoResult(len(rows), model.num_timesteps, len(rows) < settings.updates)


def initial_policy(path: Path, shape: PolicyShape, config: Config) -> Policy:
    """The policy file PPO starts from: it must read this configuration's observation layout (`parse_policy`'s
    PolicyFileError otherwise) and have the run's `shape` (ValueError naming both)."""
    policy = parse_policy(path, config).policy
    if _layout(policy.shape) != _layout(shape):
        raise ValueError(f"--init policy {path} is a {_layout(policy.shape)} policy but the run asks for a "
                         f"{_layout(shape)} one (--policy, --hidden)")
    return policy


def _layout(shape: PolicyShape) -> str:
    return f"{shape.kind} ({shape.hidden} hidden units)" if shape.kind == "mlp" else shape.kind


def _episode_summary(episodes: list[dict[str, float]]) -> dict[str, float | int]:
    """Log columns of the episodes that ended in an update (NaN means when none did)."""
    returns = np.array([episode["return"] for episode in episodes])
    summary: dict[str, float | int] = {"episodes": len(episodes)}
    summary |= {"return_mean": float(returns.mean()), "return_max": float(returns.max()),
                "return_std": float(returns.std())} if episodes else dict.fromkeys(
        ("return_mean", "return_max", "return_std"), math.nan)
    for column in ("speed_kmh", "overtakes", "lane_changes", "collisions"):
        summary[column] = float(np.mean([episode[column] for episode in episodes])) if episodes else math.nan
    return summary
