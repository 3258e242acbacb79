"""The GAIL baseline: PPO (Stable-Baselines3) on the RAIL discriminator's reward, for the paper's comparison.

Fair against RAIL: PPO's actor is RAIL's policy layout on fixed observation statistics, initialised by the same BC
(`actor`), and the discriminator, its settings and its expert normalisation are RAIL's. The environments run
in `envs` spawned processes (`envs`); the rewards are computed in this process, from the discriminator, with a
collision padded so that ending early never pays (`rewards`). After every PPO update (n_steps x envs
decisions) the discriminator takes its LS-GAN steps on the expert's pairs and that rollout's pairs, as RAIL does
once per iteration. Stable-Baselines3 is imported only by the functions that need it (`require_stable_baselines3`).

Two choices make PPO as strong as it fairly can be; each can be switched off (`GailSettings`) to measure it:
- Reward normalisation (`normalize_reward`, on by default; `rewards.normalised_rewards`): PPO's rewards are
  divided by the running std of the discounted return and clipped, the analogue of ARS dividing its step by the
  std of its returns, so that a collision's padding cannot swamp the critic.
- Critic warm-up (`critic_warmup`, 5 updates by default; `actor.set_actor_trainable`): the first updates
  freeze the actor and train only the value network, whose first advantages are noise. Warm-up decisions count in
  `timesteps` (and the discriminator trains after them as after every update); the log says which updates had the
  actor frozen.

Reproducible: env k's first episode has the Purpose.TRAIN seed of episode k from base seed x envs, later ones
follow from its `np_random`; PPO, BC and the discriminator are seeded and torch runs on one thread, so the same
settings give the same policy bit for bit (for the same number of envs).

runs/NAME/ holds `run.json` (settings, config, provenance), `policy_bc.npz` (with --bc-epochs > 0),
`policy_latest.npz` and `log.parquet`, replaced together after every update (both or, on a full disk, neither). An
environment process that dies or fails ends the run with one sentence (`envs`), not Stable-Baselines3's
EOFError; the folder keeps the last complete update. The log has one row per
update with RAIL's column names: iteration, env_steps (of this update), return_mean / _max / _std (per-decision
discriminator return, `iteration.rollout_return`, of the episodes that ended in the rollout, or of its decisions when
none did), discriminator_loss, discriminator_accuracy, collisions, wall_time_s; and episodes (ended in the
rollout), entropy (PPO's mean policy entropy [nats]), actor_frozen (a critic warm-up update) and reward_std (what
PPO's rewards were divided by at the update's end; 1 without normalisation). SIGINT / SIGTERM stop the run after
the current update, and `resume` continues from the last complete one (`sb3.resume` says what it restores
exactly and what not). `sumo-rail evaluate` takes the policy's argmax (`--policy`, as RAIL's)
or samples from its softmax, the policy PPO trains (`evaluate --policy sampled:PATH`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sumo_rail.bounds import bounded, given
from sumo_rail.config import Config, ConfigError
from sumo_rail.drivers.expert import DEFAULT_STYLE
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.learning.bc import IMITATION_BC, BcReport, BcSettings, behaviour_cloning
from sumo_rail.learning.rail.discriminator import Discriminator, DiscriminatorSettings
from sumo_rail.learning.rail.normalize import RunningStats
from sumo_rail.learning.run_folder import demos_record, start_run_folder, stop_requests
from sumo_rail.learning.sb3.actor import (
    FixedNormalisation,
    load_into_ppo,
    ppo_to_policy,
    set_actor_trainable,
)
from sumo_rail.learning.sb3.driving_envs import driving_processes
from sumo_rail.learning.sb3.resume import learner_checkpoint, restore_learner, resume_run, resumed_env_seed
from sumo_rail.learning.sb3.rewards import REWARD_CLIP as REWARD_CLIP  # importable from here, as before
from sumo_rail.learning.sb3.rewards import (
    RewardLabeller,
    labelled_vec_env,
    normalised_rewards,
    reward_std,
)
from sumo_rail.learning.sb3.runs import (
    PpoSchedule,
    build_ppo,
    env_processes,
    require_stable_baselines3,
    save_update,
)
from sumo_rail.learning.sb3.seat_road import SceneSeats
from sumo_rail.learning.torch_threads import single_thread
from sumo_rail.runners.experts import demonstrations_expert
from sumo_rail.runners.tables import Demonstrations, provenance, read_demonstrations
from sumo_rail.sim.actions import action_count
from sumo_rail.sim.observation import observation_space

if TYPE_CHECKING:
    from stable_baselines3 import PPO

INSTALL_HINT = "the GAIL baseline needs Stable-Baselines3: pip install 'sumo-rail[baselines]'"


@dataclass(frozen=True)
class GailSettings(PpoSchedule):
    """What defines a GAIL run (stored in run.json)."""

    demos: str = given("--demos")
    bc: BcSettings = given("[bc]", IMITATION_BC)
    """The behaviour cloning that initialises the actor (bc.epochs 0: PPO's own initialisation)."""
    include_failed_demos: bool = given("--include-failed", False)
    """Learn from the demonstrations' failed episodes too (`read_demonstrations`)."""
    critic_warmup: int = bounded(0, 100_000, default=5, kw_only=True)
    """First updates with the actor frozen: only the critic learns; they count in --timesteps."""
    discriminator: DiscriminatorSettings = given("[discriminator]", default_factory=DiscriminatorSettings)
    in_seats: bool = False
    """On demonstrations read from a recorded scene: PPO's episodes in that scene's train-split seats, one ego per env,
    each episode env.max_episode_s in a seat drawn by the env (`sb3.seat_road`), the others replayed; False: on the
    generated road (the paper's)."""
    seat_lead_s: float = bounded(0, 600, "s", default=5.0, kw_only=True)
    """With in_seats: the ego takes a seat this long after the car's track begins (evaluate-scene's --lead-s)."""
    seat_zone_m: float = bounded(0, 100_000, "m", default=0.0, kw_only=True)
    """With in_seats: seats where traffic is established (evaluate-scene's --zone-m)."""

    def __post_init__(self) -> None:
        self.check_schedule("gail")
        if self.in_seats and self.egos > 1:
            raise ConfigError("gail.in_seats drives one ego in each seat, so it takes no gail.egos above 1")


SEAT_SETTINGS = ("in_seats", "seat_lead_s", "seat_zone_m")
"""GAIL's settings added after runs were first written: an older run resumes at their defaults."""


@dataclass(frozen=True)
class GailResult:
    updates: int
    """Updates done (and logged)."""
    timesteps: int
    interrupted: bool
    """Stopped by SIGINT / SIGTERM before the last update."""


def train_gail(folder: Path, settings: GailSettings, config: Config,
               on_bc: Callable[[BcReport], None] | None = None,
               on_update: Callable[[dict[str, Any]], None] | None = None, resume: bool = False) -> GailResult:
    """Run GAIL into the empty or new `folder`, or with `resume` continue the run in it from its last complete update
    (`sb3.resume`); `on_bc` gets the BC report (new runs), `on_update` each new log row."""
    require_stable_baselines3(INSTALL_HINT)
    folder = Path(folder)
    observation_size = observation_space(config).shape[0]
    demos = read_demonstrations(Path(settings.demos), observation_size, settings.include_failed_demos, config.actions)
    demos_path, demos_hash = demos_record(settings.demos)
    settings = dataclasses.replace(settings, demos=demos_path)
    shape = PolicyShape(settings.kind, observation_size, settings.hidden, action_count(config.actions),
                        config.actions.decoding)
    seats = (SceneSeats.of_demonstrations(demos.metadata, settings.demos, config, settings.seat_lead_s,
                                          settings.seat_zone_m) if settings.in_seats else None)
    expert = demonstrations_expert(demos.metadata, DEFAULT_STYLE)  # recorded drivers: the rule-based stands in
    run_record = {"settings": settings.to_dict(), "expert": expert, **demos_hash,
                  **provenance("gail_run", config, settings.seed)}
    added = {field.name: field.default for field in dataclasses.fields(GailSettings) if field.name in SEAT_SETTINGS}
    checkpoint = resume_run(folder, run_record, added) if resume else None
    if checkpoint is None:
        start_run_folder(folder, run_record)
    with single_thread():
        if checkpoint is None:
            initial, normalisation = _initial_policy(folder, settings, shape, demos, run_record, on_bc)
            logs: list[dict[str, Any]] = []
        else:
            initial, normalisation, logs = None, checkpoint["normalisation"], checkpoint["log"]
        expert_stats = RunningStats.of(demos.observations)
        discriminator = Discriminator(observation_size, expert_stats.mean.copy(), expert_stats.std.copy(),
                                      settings.discriminator, shape.actions)
        horizon = round(config.env.max_episode_s / config.env.decision_period_s)
        labeller = RewardLabeller(discriminator, settings.vec_envs, horizon)
        with env_processes(folder, "GAIL", lambda: len(logs)) as processes:
            processes.venv = labelled_vec_env(driving_processes(config, settings.envs, settings.egos,
                                                                resumed_env_seed(settings.seed, len(logs)),
                                                                processes.error_dir, seats), labeller, normalisation)
            if settings.normalize_reward:
                processes.venv = normalised_rewards(processes.venv, settings.gamma)
            model = build_ppo(processes.venv, shape, settings)
            if initial is not None:
                load_into_ppo(initial, model.policy)
            if checkpoint is not None:
                restore_learner(model, checkpoint, folder / "checkpoint.pt", discriminator)
            _updates(folder, settings, shape, model, labeller, demos, normalisation, run_record, on_update, logs)
            return GailResult(len(logs), model.num_timesteps, len(logs) < settings.updates)


def _initial_policy(folder: Path, settings: GailSettings, shape: PolicyShape, demos: Demonstrations,
                    run_record: dict[str, Any], on_bc: Callable[[BcReport], None] | None,
                    ) -> tuple[Policy | None, FixedNormalisation]:
    """The BC policy (saved as policy_bc.npz) and its statistics, or None and the demonstrations' statistics."""
    if settings.bc.epochs < 1:
        stats = RunningStats.of(demos.observations)
        return None, FixedNormalisation(stats.mean.copy(), stats.std.copy())
    bc_settings = dataclasses.replace(settings.bc, seed=settings.seed)
    policy, report = behaviour_cloning(demos, shape, bc_settings)
    save_policy(policy, folder / "policy_bc.npz", {**run_record, "bc_report": dataclasses.asdict(report)})
    if on_bc is not None:
        on_bc(report)
    return policy, FixedNormalisation(policy.observation_mean, policy.observation_std)


def _updates(folder: Path, settings: GailSettings, shape: PolicyShape, model: PPO, labeller: RewardLabeller,
             demos: Demonstrations, normalisation: FixedNormalisation, run_record: dict[str, Any],
             on_update: Callable[[dict[str, Any]], None] | None, logs: list[dict[str, Any]]) -> None:
    """PPO updates, each followed by the discriminator's steps and the saves, until done or asked to stop; each
    update's log row is appended to `logs` once its files are saved."""
    with stop_requests() as stop:
        for update in range(len(logs), settings.updates):
            started = time.perf_counter()
            frozen = update < settings.critic_warmup
            set_actor_trainable(model.policy, not frozen)
            model.learn(settings.steps_per_update, reset_num_timesteps=False)
            rollout = labeller.take()
            report = labeller.discriminator.train(demos.observations, demos.actions, rollout.observations,
                                                  rollout.actions)
            returns = rollout.returns if len(rollout.returns) else rollout.rewards
            row = {"iteration": update, "env_steps": len(rollout.actions), "return_mean": float(returns.mean()),
                   "return_max": float(returns.max()), "return_std": float(returns.std()),
                   "discriminator_loss": report.loss, "discriminator_accuracy": report.accuracy,
                   "collisions": rollout.collisions, "episodes": len(rollout.returns),
                   "entropy": -float(model.logger.name_to_value["train/entropy_loss"]),
                   "actor_frozen": frozen, "reward_std": reward_std(model),
                   "wall_time_s": time.perf_counter() - started}
            save_update(folder, ppo_to_policy(model.policy, shape, normalisation), [*logs, row], run_record,
                        learner_checkpoint(model, normalisation, [*logs, row],
                                           discriminator=labeller.discriminator.state()))
            logs.append(row)
            if on_update is not None:
                on_update(row)
            if stop.is_set():
                break
