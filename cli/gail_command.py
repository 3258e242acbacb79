"""The command `gail`: the GAIL baseline (PPO on the discriminator's reward) into a run folder."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .demos_options import RECORDED_NOTE, check_demos
from .options import (
    check_egos,
    check_run_folder,
    imitation_options,
    seed_option,
    tensorboard_option,
    timesteps_options,
)
from .progress import complete, progress
from .running import (
    bc_summary,
    interruptible_run,
    sb3_interrupted,
    sb3_outcome,
    sb3_progress,
    tensorboard_logger,
)
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.bc import BcReport
    from sumo_rail.learning.settings import LearnerSettings


@click.command("gail")
@config_options(learners=("network", "bc", "discriminator", "gail"))
@imitation_options
@timesteps_options("sumo_rail.learning.sb3.gail:GailSettings")
@seed_option("Seed of everything the run draws; the same seed and settings (gail.envs, gail.egos too) give the same "
             "policy.")
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Run folder (new or empty, or the run to continue with --resume).")
@tensorboard_option
def gail_command(config: Config, settings: LearnerSettings, demos: Path, include_failed: bool, other_road: bool,
                 timesteps: int, resume: bool, seed: int, out: Path, tensorboard_dir: Path | None) -> None:
    """Train the GAIL baseline: PPO (Stable-Baselines3) on RAIL's discriminator reward, with RAIL's actor.

    Writes run.json, policy_bc.npz, policy_latest.npz (after every update; evaluate it with evaluate --policy, by
    argmax, and --policy sampled:PATH, by sampling), log.parquet (one row per update, plotted by report) and
    checkpoint.pt. Ctrl-C or SIGTERM stops after the current update with its files complete; --resume continues from
    there. Its settings are the [network], [bc], [discriminator] and [gail] sections of --config and --set
    (--help-settings lists them). Needs pip install 'sumo-rail[baselines]'.
    """
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.sb3.gail import train_gail
    from sumo_rail.learning.sb3.runs import BaselineError

    gail = settings.gail
    try:
        run = dataclasses.replace(gail, demos=str(demos), timesteps=timesteps, kind=settings.network.shape,
                                  hidden=settings.network.hidden, batch_size=gail.minibatch,
                                  bc=dataclasses.replace(settings.bc, seed=seed), seed=seed,
                                  include_failed_demos=include_failed,
                                  discriminator=dataclasses.replace(settings.discriminator, seed=seed))
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, run.egos, "gail.egos")
    check_run_folder(out)
    if check_demos(demos, config, include_failed, other_road):
        click.echo(RECORDED_NOTE)
    if run.in_seats:  # the scene is driven: refused before any work when it cannot be
        from sumo_rail.datasets import read_metadata
        from sumo_rail.learning.sb3.seat_road import SceneSeats

        try:
            SceneSeats.of_demonstrations(read_metadata(demos), demos, config, run.seat_lead_s, run.seat_zone_m)
        except ValueError as error:
            raise click.UsageError(str(error)) from error
    bar = progress(run.updates * run.steps_per_update, "GAIL", unit="timestep")

    def show_bc(report: BcReport) -> None:
        bar.write(bc_summary(report, out / "policy_bc.npz"))

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        bar.set_postfix(D_return=f"{row['return_mean']:+.3f}", collisions=row["collisions"])
        sb3_progress(bar, row, run.steps_per_update)

    # Ctrl-C before the updates start; during them gail defers it to the update's end (result.interrupted)
    with interruptible_run(bar, sb3_interrupted(out), board=tensorboard_logger(tensorboard_dir, "gail", out),
                           errors=(BaselineError, RunError)) as board:
        result = train_gail(out, run, config, on_bc=show_bc, on_update=show, resume=resume)
        if not result.interrupted:
            complete(bar)
    click.echo(sb3_outcome(result, out, run.critic_warmup))

