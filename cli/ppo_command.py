"""The command `ppo`: train a driving policy by PPO on the environment's own reward (the paper's expert)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.options import (
    DEFAULT_BATCH,
    SettingOption,
    check_egos,
    check_run_folder,
    minibatch_size,
    policy_shape_options,
    ppo_options,
    seed_option,
    setting_default,
    tensorboard_option,
)
from sumo_rail_cli.param_types import FiniteFloat
from sumo_rail_cli.progress import complete, progress
from sumo_rail_cli.running import interruptible_run, sb3_interrupted, sb3_outcome, sb3_progress, tensorboard_logger
from sumo_rail_cli.settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config

PPO = "sumo_rail.learning.sb3.ppo"
CRITIC_WARMUP_WITH_INIT = 5
"""--critic-warmup's default with --init [updates]."""


@click.command("ppo")
@config_options
@policy_shape_options
@ppo_options("sumo_rail.learning.sb3.ppo:PpoSettings",
             critic_help=f"; with --init only  [default: {CRITIC_WARMUP_WITH_INIT} with --init, else 0]")
@click.option("--batch-size", type=click.IntRange(min=2), default=None,
              help=f"PPO minibatch size, at most an update's decisions  [default: {DEFAULT_BATCH}, or an update's "
                   f"decisions if fewer].")
@click.option("--ent-coef", cls=SettingOption, type=FiniteFloat(min=0),
              default=setting_default(PPO, "PpoSettings.ent_coef"), show_default=True,
              help="PPO's entropy bonus.")
@click.option("--gamma", cls=SettingOption, type=FiniteFloat(min=0, max=1, min_open=True),
              default=setting_default(PPO, "PpoSettings.gamma"), show_default=True,
              help="Discount per decision.")
@click.option("--overtake-reward", cls=SettingOption, type=FiniteFloat(min=0),
              default=setting_default(PPO, "PpoSettings.overtake_reward"), show_default=True,
              help="Reward shaping: added for every vehicle the ego overtakes (0: the env's reward alone).")
@click.option("--keep-right-reward", cls=SettingOption, type=FiniteFloat(min=0),
              default=setting_default(PPO, "PpoSettings.keep_right_reward"), show_default=True,
              help="Reward shaping: added per decision in the rightmost lane, falling linearly to 0 in the leftmost "
                   "(the rule-based expert's keep-right rule; 0: the env's reward alone).")
@click.option("--init", "init", type=click.Path(path_type=Path, dir_okay=False, exists=True), default=None,
              metavar="POLICY_FILE", help="Start the actor from this policy file (a BC, DAgger or earlier PPO policy "
              "of the same --policy/--hidden and observation layout) instead of a random one: RL fine-tuning of a "
              "cloned driver.")
@seed_option("Seed of everything the run draws; the same seed, --envs and --egos give the same policy.")
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Run folder (new or empty, or the run to continue with --resume).")
@tensorboard_option
def ppo_command(config: Config, kind: str, hidden: int, timesteps: int, envs: int, egos: int, n_steps: int,
                batch_size: int | None, learning_rate: float, ent_coef: float, gamma: float, normalize_reward: bool,
                overtake_reward: float, keep_right_reward: float, init: Path | None, critic_warmup: int | None,
                resume: bool, seed: int, out: Path, tensorboard_dir: Path | None) -> None:
    """Train a driver by PPO (Stable-Baselines3) on the env's reward: speed, lane-change cost, collisions.

    Writes run.json, policy_latest.npz (after every update: a policy file that evaluate --policy drives and that
    record-expert, evaluate and dagger take as --expert), log.parquet (one row per update: return, speed,
    overtakes, lane changes and collisions of the episodes that ended) and checkpoint.pt. Ctrl-C or SIGTERM stops
    after the current update with its files complete; --resume continues from there. Needs pip install
    'sumo-rail[baselines]'.
    """
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.sb3.ppo import PpoSettings, initial_policy, train_ppo_driver
    from sumo_rail.learning.sb3.runs import BaselineError

    if critic_warmup is None:
        critic_warmup = CRITIC_WARMUP_WITH_INIT if init is not None else 0
    try:
        settings = PpoSettings(timesteps=timesteps, kind=kind, hidden=hidden, envs=envs, egos=egos,
                               n_steps=n_steps, batch_size=minibatch_size(batch_size, n_steps, envs, egos),
                               learning_rate=learning_rate, gamma=gamma, ent_coef=ent_coef,
                               normalize_reward=normalize_reward, overtake_reward=overtake_reward,
                               keep_right_reward=keep_right_reward, init=None if init is None else str(init),
                               critic_warmup=critic_warmup, seed=seed)
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, egos)
    check_run_folder(out)
    if init is not None and not resume:
        try:
            initial_policy(init, settings.shape(config), config)
        except PolicyFileError as error:
            raise click.ClickException(str(error)) from error
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="'--init'") from error
    bar = progress(settings.updates * settings.steps_per_update, "PPO", unit="timestep")

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        bar.set_postfix(speed_kmh=f"{row['speed_kmh']:.1f}", overtakes=f"{row['overtakes']:.2f}",
                        lane_changes=f"{row['lane_changes']:.2f}", collisions=f"{row['collisions']:.2f}")
        sb3_progress(bar, row, settings.steps_per_update)

    with interruptible_run(bar, sb3_interrupted(out), board=tensorboard_logger(tensorboard_dir, "ppo", out),
                           errors=(BaselineError, RunError)) as board:
        result = train_ppo_driver(out, settings, config, on_update=show, resume=resume)
        if not result.interrupted:
            complete(bar)
    click.echo(sb3_outcome(result, out, settings.critic_warmup))

