"""The command `dagger`: DAgger with the expert labelling the learner's own states, into a run folder."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from .demos_options import RECORDED_NOTE, check_demos
from .options import (
    build_backend,
    check_egos,
    check_run_folder,
    checked_roads,
    expert_option,
    imitation_options,
    resolve_expert_option,
    roads_option,
    run_folder_options,
    tensorboard_option,
)
from .progress import advance_to, complete, progress
from .running import interruptible_run, kept_until_resume, tensorboard_logger, validation_summary
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.settings import LearnerSettings

DAGGER = "sumo_rail.learning.dagger"


@click.command("dagger")
@config_options(learners=("network", "bc", "dagger"))
@imitation_options
@click.option("--rounds", type=click.IntRange(min=0), default=5, show_default=True,
              help="Rounds after the first BC (with --resume: including those already done).")
@roads_option("each round's episodes")
@expert_option("Who labels the learner's states [default: the demonstrations' expert]. 'log' on demonstrations "
               "read from a recorded scene (recorded-demos, acceleration interface): training against the log, the "
               "learner driving in the scene's train-split seats, each state labelled with the acceleration and lane "
               "change that best return it to the seated car's recorded track over dagger.teacher_horizon_s.",
               default=None)
@run_folder_options("round", eval_every=1)
@tensorboard_option
def dagger_command(config: Config, settings: LearnerSettings, demos: Path, include_failed: bool, other_road: bool,
                   rounds: int, roads: tuple[str, ...] | None, expert: str | None, workers: int, backend_name: str,
                   address: str | None, seed: int, eval_every: int, eval_episodes: int, out: Path, resume: bool,
                   tensorboard_dir: Path | None) -> None:
    """Learn a driving policy with DAgger: BC on the demonstrations, then rounds in which the expert labels every
    state the policy (mixed with the expert, probability beta) visits, and BC again on all labels so far.

    Writes run.json, dataset.parquet, policy_bc.npz, policy_latest.npz (evaluate it with evaluate --policy),
    log.parquet (one row per round) and checkpoint.json. Ctrl-C or SIGTERM keeps the last complete round;
    --resume continues it with the same result. Its settings are the [network], [bc] and [dagger] sections of --config
    and --set (--help-settings lists them); every round is behaviour cloning, so bc.epochs is at least 1.

    Against the log (--expert log) the teacher knows only the seated car's recorded future: not why it drove so, nor
    what the others would do once the ego leaves its track (they replay theirs), so a label far from the track says
    "go back" whatever the traffic there, and states after the track's end have none (docs/recordings.md)."""
    from sumo_rail.datasets import DatasetError, read_metadata
    from sumo_rail.learning.dagger import train_dagger
    from sumo_rail.learning.log_dagger import LOG_TEACHER, LogSeats
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.train_seats import SceneSeatsError
    from sumo_rail.learning.validation import Validation

    if expert is not None and expert != LOG_TEACHER:
        expert, _ = resolve_expert_option(expert, config, drives=True)
    try:
        run = dataclasses.replace(settings.dagger, demos=str(demos), kind=settings.network.shape,
                                  hidden=settings.network.hidden, bc=dataclasses.replace(settings.bc, seed=seed),
                                  seed=seed, expert=expert, roads=checked_roads(config, roads),
                                  include_failed_demos=include_failed)
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, run.egos, "dagger.egos")
    check_run_folder(out)
    log = None
    if expert == LOG_TEACHER:
        try:  # the scene and its seats, before any work
            log = LogSeats.of(read_metadata(demos), str(demos), config, run.seat_lead_s, run.seat_s,
                              run.teacher_horizon_s, run.seat_zone_m)
        except (DatasetError, SceneSeatsError) as error:
            raise click.UsageError(str(error)) from error
    recorded = check_demos(demos, config, include_failed, other_road)
    if recorded:
        click.echo(RECORDED_NOTE)
    asked = "with the rule-based normal style, not the recorded drivers: " if recorded else ""
    backend = build_backend(backend_name, workers, address)
    bar = progress(rounds + 1, "DAgger", unit="round")

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        advance_to(bar, row["iteration"] + 1)  # a resumed run starts from the rounds done
        holdout = row["bc_holdout_accuracy"]
        text = (f"round {row['iteration']}: {row['dataset_rows']} labelled states, BC holdout accuracy "
                f"{'n/a' if holdout is None else f'{holdout:.3f}'}")
        if row.get("eval_agreement") is not None:
            text += f", {asked}{validation_summary(row, eval_episodes)}"
        bar.write(text)

    with interruptible_run(bar, lambda: kept_until_resume(out, "round", "checkpoint.json"), backend,
                           tensorboard_logger(tensorboard_dir, "dagger", out),
                           errors=(RunError, SceneSeatsError)) as board:
        train_dagger(out, run, config, rounds, backend, resume, Validation(eval_every, eval_episodes),
                     on_round=show, log=log)
        complete(bar)
    click.echo(f"DAgger: {rounds} round{'s' * (rounds != 1)}; policy in {out / 'policy_latest.npz'}")
