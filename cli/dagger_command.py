"""The command `dagger`: DAgger with the expert labelling the learner's own states, into a run folder."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from sumo_rail_cli.demos_options import check_demos
from sumo_rail_cli.options import (
    SettingOption,
    build_backend,
    check_egos,
    check_run_folder,
    checked_roads,
    egos_option,
    expert_option,
    imitation_options,
    resolve_expert_option,
    roads_option,
    run_folder_options,
    setting_default,
    tensorboard_option,
)
from sumo_rail_cli.param_types import FiniteFloat
from sumo_rail_cli.progress import advance_to, complete, progress
from sumo_rail_cli.running import interruptible_run, kept_until_resume, tensorboard_logger, validation_summary
from sumo_rail_cli.settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config

DAGGER = "sumo_rail.learning.dagger"


@click.command("dagger")
@config_options
@imitation_options
@click.option("--rounds", type=click.IntRange(min=0), default=5, show_default=True,
              help="Rounds after the first BC (with --resume: including those already done).")
@click.option("--episodes-per-round", cls=SettingOption, type=click.IntRange(min=1),
              default=setting_default(DAGGER, "DaggerSettings.episodes_per_round"), show_default=True,
              help="Episodes the mixture of policy and expert drives each round.")
@click.option("--beta", cls=SettingOption, type=FiniteFloat(0, 1),
              default=setting_default(DAGGER, "DaggerSettings.beta"), show_default=True,
              help="Probability that the expert drives a decision in round 1.")
@click.option("--beta-decay", cls=SettingOption, type=FiniteFloat(0, 1),
              default=setting_default(DAGGER, "DaggerSettings.beta_decay"), show_default=True,
              help="beta of round r: beta x beta-decay^(r - 1).")
@roads_option("each round's episodes")
@egos_option("Episodes of a round")
@expert_option("Who labels the learner's states [default: the demonstrations' expert].", default=None)
@run_folder_options("round", eval_every=1)
@tensorboard_option
def dagger_command(config: Config, demos: Path, include_failed: bool, other_road: bool, kind: str, hidden: int,
                   bc_epochs: int, bc_class_balance: float, rounds: int, episodes_per_round: int, beta: float,
                   beta_decay: float, roads: str, egos: int, expert: str | None, workers: int, backend_name: str,
                   address: str | None, seed: int, eval_every: int, eval_episodes: int, out: Path, resume: bool,
                   tensorboard_dir: Path | None) -> None:
    """Learn a driving policy with DAgger: BC on the demonstrations, then rounds in which the expert labels every
    state the policy (mixed with the expert, probability beta) visits, and BC again on all labels so far.

    Writes run.json, dataset.parquet, policy_bc.npz, policy_latest.npz (evaluate it with evaluate --policy),
    log.parquet (one row per round) and checkpoint.json. Ctrl-C or SIGTERM keeps the last complete round;
    --resume continues it with the same result."""
    from sumo_rail.learning.bc import BcSettings
    from sumo_rail.learning.dagger import DaggerSettings, train_dagger
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.validation import Validation

    if expert is not None:
        expert, _ = resolve_expert_option(expert, config)
    try:
        settings = DaggerSettings(str(demos), kind, hidden, episodes_per_round, beta, beta_decay,
                                  BcSettings(epochs=max(bc_epochs, 1), class_balance=bc_class_balance, seed=seed),
                                  seed, expert, egos, checked_roads(config, roads), include_failed)
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, egos)
    check_run_folder(out)
    check_demos(demos, config, include_failed, other_road)
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
            text += f", {validation_summary(row, eval_episodes)}"
        bar.write(text)

    with interruptible_run(bar, lambda: kept_until_resume(out, "round", "checkpoint.json"), backend,
                           tensorboard_logger(tensorboard_dir, "dagger", out), errors=(RunError,)) as board:
        train_dagger(out, settings, config, rounds, backend, resume, Validation(eval_every, eval_episodes),
                     on_round=show)
        complete(bar)
    click.echo(f"DAgger: {rounds} round{'s' * (rounds != 1)}; policy in {out / 'policy_latest.npz'}")
