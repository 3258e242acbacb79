"""The command `ppo`: train a driving policy by PPO on the environment's own reward (the paper's expert)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .options import check_egos, check_run_folder, seed_option, tensorboard_option, timesteps_options
from .progress import complete, progress
from .running import interruptible_run, sb3_interrupted, sb3_outcome, sb3_progress, tensorboard_logger
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.settings import LearnerSettings

CRITIC_WARMUP_WITH_INIT = 5
"""ppo.critic_warmup's default with --init [updates]."""


@click.command("ppo")
@config_options(learners=("network", "ppo"))
@timesteps_options("sumo_rail.learning.sb3.ppo:PpoSettings")
@click.option("--init", "init", type=click.Path(path_type=Path, dir_okay=False, exists=True), default=None,
              metavar="POLICY_FILE", help="Start the actor from this policy file (a BC, DAgger or earlier PPO policy "
              "of the same network.shape, network.hidden and observation layout) instead of a random one: RL "
              f"fine-tuning of a cloned driver (ppo.critic_warmup then defaults to {CRITIC_WARMUP_WITH_INIT}).")
@seed_option("Seed of everything the run draws; the same seed and settings (ppo.envs, ppo.egos too) give the same "
             "policy.")
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Run folder (new or empty, or the run to continue with --resume).")
@tensorboard_option
def ppo_command(config: Config, settings: LearnerSettings, timesteps: int, init: Path | None, resume: bool,
                seed: int, out: Path, tensorboard_dir: Path | None) -> None:
    """Train a driver by PPO (Stable-Baselines3) on the env's reward: speed, lane-change cost, collisions.

    Writes run.json, policy_latest.npz (after every update: a policy file that evaluate --policy drives and that
    record-expert, evaluate and dagger take as --expert), log.parquet (one row per update: return, speed,
    overtakes, lane changes and collisions of the episodes that ended) and checkpoint.pt. Ctrl-C or SIGTERM stops
    after the current update with its files complete; --resume continues from there. Its settings are the [network]
    and [ppo] sections of --config and --set (--help-settings lists them). Needs pip install 'sumo-rail[baselines]'.
    """
    from sumo_rail.drivers.policies import PolicyFileError, PolicyInterfaceError
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.sb3.ppo import initial_policy, train_ppo_driver
    from sumo_rail.learning.sb3.runs import BaselineError

    ppo = settings.ppo
    warmup = (CRITIC_WARMUP_WITH_INIT if init is not None and "ppo.critic_warmup" not in settings.chosen
              else ppo.critic_warmup)
    try:
        run = dataclasses.replace(ppo, timesteps=timesteps, kind=settings.network.shape,
                                  hidden=settings.network.hidden, batch_size=ppo.minibatch,
                                  init=None if init is None else str(init), critic_warmup=warmup, seed=seed)
        run.check_warmup()
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, run.egos, "ppo.egos")
    check_run_folder(out)
    if init is not None and not resume:
        try:
            initial_policy(init, run.shape(config), config)
        except PolicyInterfaceError as error:
            raise click.BadParameter(str(error), param_hint="'--init'") from error
        except PolicyFileError as error:
            raise click.ClickException(str(error)) from error
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="'--init'") from error
    bar = progress(run.updates * run.steps_per_update, "PPO", unit="timestep")

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        bar.set_postfix(speed_kmh=f"{row['speed_kmh']:.1f}", overtakes=f"{row['overtakes']:.2f}",
                        lane_changes=f"{row['lane_changes']:.2f}", collisions=f"{row['collisions']:.2f}")
        sb3_progress(bar, row, run.steps_per_update)

    with interruptible_run(bar, sb3_interrupted(out), board=tensorboard_logger(tensorboard_dir, "ppo", out),
                           errors=(BaselineError, RunError)) as board:
        result = train_ppo_driver(out, run, config, on_update=show, resume=resume)
        if not result.interrupted:
            complete(bar)
    click.echo(sb3_outcome(result, out, run.critic_warmup))

