"""The command `gail`: the GAIL baseline (PPO on the discriminator's reward) into a run folder."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.options import (
    check_egos,
    config_options,
    imitation_options,
    ppo_options,
    seed_option,
    tensorboard_option,
)
from sumo_rail_cli.progress import progress
from sumo_rail_cli.running import bc_summary, interruptible_run, tensorboard_logger

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.bc import BcReport
    from sumo_rail.learning.gail import GailResult, GailSettings


@click.command("gail")
@config_options
@imitation_options
@ppo_options(default_timesteps=100_000, critic_help="")
@seed_option("Seed of everything the run draws; the same seed, --envs and --egos give the same policy.")
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Run folder (new or empty).")
@tensorboard_option
def gail_command(config: Config, demos: Path, timesteps: int, kind: str,
                 hidden: int, bc_epochs: int, bc_class_balance: float, envs: int, egos: int, n_steps: int,
                 learning_rate: float, normalize_reward: bool, critic_warmup: int, seed: int, out: Path,
                 tensorboard_dir: Path | None) -> None:
    """Train the GAIL baseline: PPO (Stable-Baselines3) on RAIL's discriminator reward, with RAIL's actor.

    Writes run.json, policy_bc.npz, policy_latest.npz (after every update; evaluate it with evaluate --policy, by
    argmax, and --sample-policy, by sampling) and log.parquet (one row per update, plotted by report). Ctrl-C or
    SIGTERM stops after the current update with its files complete; a GAIL run cannot be resumed. Needs pip
    install 'sumo-rail[baselines]'.
    """
    from sumo_rail.learning.discriminator import DiscriminatorSettings
    from sumo_rail.learning.gail import GailSettings, train_gail
    from sumo_rail.learning.sb3_runs import BaselineError
    from sumo_rail.learning.training import RunError

    try:
        settings = GailSettings(str(demos), timesteps=timesteps, kind=kind, hidden=hidden, bc_epochs=bc_epochs,
                                bc_class_balance=bc_class_balance, envs=envs, egos=egos, n_steps=n_steps,
                                learning_rate=learning_rate, normalize_reward=normalize_reward,
                                critic_warmup=critic_warmup, seed=seed, discriminator=DiscriminatorSettings(seed=seed))
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, egos)
    bar = progress(settings.updates * settings.steps_per_update, "GAIL", unit="timestep")

    def show_bc(report: BcReport) -> None:
        bar.write(bc_summary(report, out / "policy_bc.npz"))

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        bar.set_postfix(D_return=f"{row['return_mean']:+.3f}", collisions=row["collisions"])
        bar.update(row["env_steps"])

    # Ctrl-C before the updates start; during them gail defers it to the update's end (result.interrupted)
    with interruptible_run(bar, f"interrupted before the first update; {out} holds no trained policy",
                           board=tensorboard_logger(tensorboard_dir, "gail", out),
                           errors=(BaselineError, RunError)) as board:
        result = train_gail(out, settings, config, on_bc=show_bc, on_update=show)
    if result.interrupted:
        raise click.ClickException(f"interrupted after {result.updates} updates; {out / 'policy_latest.npz'} holds the "
                                   f"last one's policy (a GAIL run cannot be resumed)")
    click.echo(f"trained {result.updates} PPO updates ({result.timesteps} timesteps{_warmup_note(settings, result)}); "
               f"policy in {out / 'policy_latest.npz'}")


def _warmup_note(settings: GailSettings, result: GailResult) -> str:
    """How many of the updates done only trained the critic, when any did."""
    frozen = min(settings.critic_warmup, result.updates)
    if frozen == result.updates:
        return f"; the actor frozen in all {frozen} for the critic's warm-up, so the policy is the initial one"
    return f"; the actor frozen in the first {frozen} for the critic's warm-up" if frozen else ""
