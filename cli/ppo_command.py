"""The command `ppo`: train a driving policy by PPO on the environment's own reward (the paper's expert)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.options import (
    check_egos,
    config_options,
    policy_shape_options,
    ppo_options,
    seed_option,
    tensorboard_option,
)
from sumo_rail_cli.progress import progress
from sumo_rail_cli.running import interruptible_run, tensorboard_logger

if TYPE_CHECKING:
    from sumo_rail.config import Config


@click.command("ppo")
@config_options
@policy_shape_options
@ppo_options(default_timesteps=400_000, critic_help="; with --init only")
@click.option("--batch-size", type=click.IntRange(min=2), default=64, show_default=True,
              help="PPO minibatch size [decisions].")
@click.option("--ent-coef", type=click.FloatRange(min=0), default=0.01, show_default=True,
              help="PPO's entropy bonus.")
@click.option("--gamma", type=click.FloatRange(min=0, max=1, min_open=True), default=0.99, show_default=True,
              help="Discount per decision.")
@click.option("--overtake-reward", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Reward shaping: added for every vehicle the ego overtakes (0: the env's reward alone).")
@click.option("--keep-right-reward", type=click.FloatRange(min=0), default=0.0, show_default=True,
              help="Reward shaping: added per decision in the rightmost lane, falling linearly to 0 in the leftmost "
                   "(the rule-based expert's keep-right rule; 0: the env's reward alone).")
@click.option("--init", "init", type=click.Path(path_type=Path, dir_okay=False, exists=True), default=None,
              metavar="POLICY_FILE", help="Start the actor from this policy file (a BC, DAgger or earlier PPO policy "
              "of the same --policy/--hidden and observation layout) instead of a random one: RL fine-tuning of a "
              "cloned driver.")
@seed_option("Seed of everything the run draws; the same seed, --envs and --egos give the same policy.")
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Run folder (new or empty).")
@tensorboard_option
def ppo_command(config: Config, kind: str, hidden: int, timesteps: int, envs: int, egos: int, n_steps: int,
                batch_size: int, learning_rate: float, ent_coef: float, gamma: float, normalize_reward: bool,
                overtake_reward: float, keep_right_reward: float, init: Path | None, critic_warmup: int, seed: int,
                out: Path, tensorboard_dir: Path | None) -> None:
    """Train a driver by PPO (Stable-Baselines3) on the env's reward: speed, lane-change cost, collisions.

    Writes run.json, policy_latest.npz (after every update: a policy file that evaluate --policy drives and that
    record-expert, evaluate and dagger take as --expert) and log.parquet (one row per update: return, speed,
    overtakes, lane changes and collisions of the episodes that ended). Ctrl-C or SIGTERM stops after the current
    update with its files complete; a PPO run cannot be resumed. Needs pip install 'sumo-rail[baselines]'.
    """
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.learning.ppo_driver import PpoSettings, initial_policy, train_ppo_driver
    from sumo_rail.learning.sb3_runs import BaselineError
    from sumo_rail.learning.training import RunError

    try:
        settings = PpoSettings(timesteps=timesteps, kind=kind, hidden=hidden, envs=envs, egos=egos,
                               n_steps=n_steps, batch_size=batch_size, learning_rate=learning_rate, gamma=gamma,
                               ent_coef=ent_coef, normalize_reward=normalize_reward, overtake_reward=overtake_reward,
                               keep_right_reward=keep_right_reward, init=None if init is None else str(init),
                               critic_warmup=critic_warmup, seed=seed)
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, egos)
    if init is not None:
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
        bar.update(row["env_steps"])

    with interruptible_run(bar, f"interrupted before the first update; {out} holds no trained policy",
                           board=tensorboard_logger(tensorboard_dir, "ppo", out),
                           errors=(BaselineError, RunError)) as board:
        result = train_ppo_driver(out, settings, config, on_update=show)
    if result.interrupted:
        raise click.ClickException(f"interrupted after {result.updates} updates; {out / 'policy_latest.npz'} holds the "
                                   f"last one's policy (a PPO run cannot be resumed)")
    click.echo(f"trained {result.updates} PPO updates ({result.timesteps} timesteps); policy in "
               f"{out / 'policy_latest.npz'}")
