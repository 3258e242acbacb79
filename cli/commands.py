"""The commands `record-expert` and `evaluate`: options -> config -> one library call -> printed summary."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from sumo_rail.seeding import EVALUATION_EPISODES

from .demos_options import RECORDED_NOTE, check_demos
from .evaluation_options import (
    check_video_dir,
    check_watching,
    evaluation_backend,
    parse_drivers,
    watching_options,
    write_videos,
)
from .options import (
    backend_options,
    build_backend,
    check_egos,
    check_output,
    check_run_folder,
    checked_roads,
    egos_option,
    episode_options,
    expert_option,
    imitation_options,
    output_options,
    resolve_expert_option,
    roads_option,
    run_folder_options,
    tensorboard_option,
)
from .param_types import FiniteFloat
from .progress import advance_to, complete, progress, start_at
from .running import (
    bc_summary,
    failures_summary,
    interruptible_run,
    kept_until_resume,
    tensorboard_logger,
    validation_summary,
)
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.learning.bc import BcReport
    from sumo_rail.learning.settings import LearnerSettings


@click.command("record-expert")
@config_options
@episode_options(default_seed=0, default_episodes=40)
@backend_options
@expert_option("Who is recorded.")
@egos_option("Episodes", "An ego that finds no room is not recorded.")
@click.option("--dart-noise", type=FiniteFloat(0.0, 1.0, max_open=True), default=0.0, show_default=True,
              metavar="EPSILON", help="DART: at each decision, with this probability, the car executes a uniformly "
                                      "random action instead of the expert's; every record keeps the expert's.")
@output_options(required=True)
def record_expert(config: Config, episodes: int, seed: int, workers: int, backend_name: str, address: str | None,
                  expert: str, egos: int, dart_noise: float, out: Path, overwrite: bool) -> None:
    """Record an expert's demonstrations (the rule-based driver of a style, or any policy file): one Parquet row per
    decision."""
    check_output(out, overwrite)
    check_egos(config, egos)
    expert, driver = resolve_expert_option(expert, config, drives=True)
    from sumo_rail.runners.dart import ActionNoise
    from sumo_rail.runners.record import record_demonstrations

    backend = build_backend(backend_name, workers, address)
    bar = progress(episodes, "recording")
    with interruptible_run(bar, backend=backend):
        metrics = record_demonstrations(config, driver, expert, seed, episodes, backend, out,
                                        on_episode=lambda index, result: bar.update(
                                            len(result) if isinstance(result, list) else 1), egos=egos,
                                        noise=ActionNoise(dart_noise) if dart_noise else None)
        complete(bar)
    decisions = sum(row["steps"] for row in metrics)
    failures = {name: sum(row[name] for row in metrics) for name in ("collisions", "missed_exits", "lane_end_stops")}
    noise = f", DART noise {dart_noise:g}" if dart_noise else ""
    click.echo(f"wrote {out}: {len(metrics)} episodes, {decisions} decisions, expert {expert}{noise}, "
               f"{failures_summary(failures)}")


@click.command("evaluate")
@config_options
@click.option("--policy", "policies", multiple=True, default=("expert",), show_default=True,
              metavar="expert[:STYLE]|keep|random|PATH|sampled:PATH",
              help="Driver to evaluate (repeatable: drivers side by side on the same seeds): the expert (of a style), "
                   "the constant set-point, uniformly random actions, a policy file by the argmax of its logits, or "
                   "one drawing each action from their softmax (named 'NAME (sampled)'; at "
                   "actions.sampling_temperature T below 1, the softmax of the logits over T, 'NAME (sampled at T)'), "
                   "with a generator seeded by the episode's seed.")
@expert_option("The expert: the driver --policy expert, and who is asked at every decision what it would do, for "
               "every driver. Without it each driver is compared with the expert its policy file records (the one "
               "whose demonstrations trained it), others with the normal style; the table names it per driver.",
               default=None)
@click.option("--reference", default=None, metavar="NAME",
              help="Driver the others are compared with, paired by seed (default: the first --policy).")
@click.option("--pool", type=click.Choice(["test", "validation"]), default="test", show_default=True,
              help="Warm traffic states the episodes start from: test (held out from everything) or validation (for "
                   "choosing settings; use another --seed than the test runs' too).")
@episode_options(default_seed=1000, default_episodes=EVALUATION_EPISODES)
@backend_options
@watching_options
@output_options(required=False)
def evaluate_command(config: Config, policies: tuple[str, ...],
                     expert: str | None, reference: str | None,
                     pool: str, episodes: int, seed: int, workers: int, backend_name: str, address: str | None,
                     gui: bool, gui_delay_ms: float | None, video_dir: Path | None, video_episodes: int | None,
                     out: Path | None, overwrite: bool) -> None:
    """Evaluate drivers on held-out episodes and compare them with the expert and with each other.

    Prints each measure's mean with its 95% interval (on-policy agreement with the expert first, then the paper's
    metrics), every driver's paired difference to --reference, and the distances of its speed, headway, lane and
    action distributions to the reference expert's when that expert is among the drivers. --out gets one row per
    episode and NAME.decisions.parquet beside it one row per decision. --video writes DRIVER_episodeNNN_seedS.mp4
    files into a folder."""
    check_output(out, overwrite)
    check_watching(gui, gui_delay_ms, video_dir, video_episodes)
    from sumo_rail.drivers.expert import DEFAULT_STYLE
    from sumo_rail.evaluation.evaluate import decisions_path, evaluate, policy_source, recorded_reference
    from sumo_rail.evaluation.protocol import summarise, unique_names, write_evaluation
    from sumo_rail.seeding import Purpose, episode_seeds

    if out is not None:
        check_output(decisions_path(out), overwrite)
    recorded_expert, expert_driver = resolve_expert_option(expert or DEFAULT_STYLE, config)
    drivers = parse_drivers(policies, config, expert_driver)
    try:  # an explicit --expert is every driver's; without it, each its own file's
        references = [expert_driver if expert is not None else recorded_reference(driver, policy_source(text), config,
                                                                                  expert_driver)
                      for driver, text in zip(drivers, policies, strict=True)]
    except ValueError as error:  # a PolicyFileError, or a file recording an expert that is no style nor file
        raise click.ClickException(str(error)) from error
    if gui:
        drivers, references, episodes = drivers[:1], references[:1], 1
    names = unique_names(drivers)
    check_video_dir(video_dir, names, overwrite)  # held, and named by a stop: written or not
    if reference is not None and reference not in names:
        raise click.BadParameter(f"{reference!r} is not one of the drivers ({', '.join(names)})",
                                 param_hint="'--reference'")
    seeds = episode_seeds(Purpose.EVALUATE, seed, episodes)
    backend = evaluation_backend(backend_name, workers, address, gui, gui_delay_ms)
    bar = progress(len(drivers) * episodes, "evaluating")
    with interruptible_run(bar, backend=backend):
        evaluation = evaluate(drivers, config, seeds, backend, references, pool,
                              on_episode=lambda index, result: bar.update(),
                              video_episodes=(video_episodes or 1) if video_dir is not None else 0)
        if out is not None:
            write_evaluation(evaluation, config, seed, out, policies=list(policies), episode_seeds=seeds,
                             expert=recorded_expert if expert is not None else None, pool=pool)
        written_videos = write_videos(evaluation.videos, video_dir)
        complete(bar)
    click.echo(summarise(evaluation, config, reference, expert_driver.name))
    if out is not None:
        click.echo(f"wrote {out}: {len(evaluation.metrics)} episodes; {decisions_path(out)}: "
                   f"{len(evaluation.decisions)} decisions")
    if written_videos:
        click.echo(f"wrote {len(written_videos)} videos into {video_dir}: {', '.join(written_videos)}")


@click.command("train")
@config_options(learners=("network", "bc", "rail", "discriminator"))
@imitation_options
@click.option("--iterations", type=click.IntRange(min=1), default=200, show_default=True,
              help="Iterations in total (with --resume: including those already done).")
@roads_option("the directions' rollouts")
@run_folder_options("iteration", eval_every=10)
@tensorboard_option
def train_command(config: Config, settings: LearnerSettings, demos: Path, include_failed: bool, other_road: bool,
                  iterations: int, roads: tuple[str, ...] | None, workers: int, backend_name: str, address: str | None,
                  seed: int, eval_every: int, eval_episodes: int, out: Path, resume: bool,
                  tensorboard_dir: Path | None) -> None:
    """Learn a driving policy from demonstrations with RAIL (BC initialisation, then ARS with an LS-GAN reward).

    Its settings are the sections [network], [bc], [rail] and [discriminator] of --config and --set (e.g. --set
    rail.directions=16 --set network.shape=linear); --help-settings lists them. run.json stores them whole."""
    from sumo_rail.datasets import DatasetError, read_metadata
    from sumo_rail.learning.rail.seat_rollouts import rail_seats
    from sumo_rail.learning.rail.trainer import RunSettings, train
    from sumo_rail.learning.run_folder import RunError
    from sumo_rail.learning.train_seats import SceneSeatsError
    from sumo_rail.learning.validation import Validation

    try:
        rail = dataclasses.replace(settings.rail, seed=seed, roads=checked_roads(config, roads))
    except ValueError as error:
        raise click.UsageError(str(error)) from error
    check_egos(config, rail.egos, "rail.egos")
    check_run_folder(out)
    discriminator = dataclasses.replace(settings.discriminator, seed=seed)
    run = RunSettings(str(demos), settings.network.shape, settings.network.hidden, rail, discriminator,
                      dataclasses.replace(settings.bc, seed=seed), include_failed_demos=include_failed)
    recorded = check_demos(demos, config, include_failed, other_road)
    try:  # the scene and its seats, before any work
        in_seats = rail_seats(rail, read_metadata(demos), str(demos), config) if rail.rollout_seats else None
    except (DatasetError, SceneSeatsError) as error:
        raise click.UsageError(str(error)) from error
    if recorded:
        click.echo(RECORDED_NOTE)
    asked = "with the rule-based normal style, not the recorded drivers: " if recorded else ""
    backend = build_backend(backend_name, workers, address)
    bar = progress(iterations, "training", unit="iteration")

    def show_bc(report: BcReport) -> None:
        bar.write(bc_summary(report, out / "policy_bc.npz"))

    def show(row: dict[str, Any]) -> None:
        if board is not None:
            board.log(row)
        steps_per_s = row["env_steps"] / row["wall_time_s"]
        bar.set_postfix(D_return=f"{row['return_mean']:+.3f}", steps_per_s=f"{steps_per_s:.0f}")
        advance_to(bar, row["iteration"] + 1)
        if row["eval_average_speed_kmh"] is not None:
            bar.write(f"iteration {row['iteration'] + 1}: {asked}{validation_summary(row, eval_episodes)}")

    with interruptible_run(bar, lambda: kept_until_resume(out, "iteration"), backend,
                           tensorboard_logger(tensorboard_dir, "rail", out), errors=(RunError,)) as board:
        state = train(out, run, config, iterations, backend, resume, Validation(eval_every, eval_episodes),
                      on_bc=show_bc, on_iteration=show, on_start=lambda done: start_at(bar, done), in_seats=in_seats)
        complete(bar)
    click.echo(f"trained {state.iteration} iteration{'s' * (state.iteration != 1)}; policies in {out}")

