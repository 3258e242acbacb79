"""The commands `record-expert` and `evaluate`: options -> config -> one library call -> printed summary."""

from __future__ import annotations

from pathlib import Path

import click
from sumo_rail_cli.options import (
    check_output,
    config_options,
    episode_options,
    episode_progress,
    library_errors,
    output_options,
    resolve_config,
)

from sumo_rail.expert import DEFAULT_STYLE, STYLES

_STYLE = click.Choice(sorted(STYLES))


@click.command("record-expert")
@config_options
@episode_options(default_seed=0, default_episodes=40)
@click.option("--style", type=_STYLE, default=DEFAULT_STYLE, show_default=True, help="Expert driving style.")
@output_options(required=True)
def record_expert(config_path: Path | None, overrides: tuple[str, ...], episodes: int, seed: int, workers: int,
                  style: str, out: Path, overwrite: bool) -> None:
    """Record the rule-based expert's demonstrations: one Parquet row per decision."""
    config = resolve_config(config_path, overrides)
    check_output(out, overwrite)
    from sumo_rail.backends import ProcessPoolBackend
    from sumo_rail.record import record_demonstrations

    with library_errors(), ProcessPoolBackend(workers) as backend, episode_progress(episodes, "recording") as bar:
        metrics = record_demonstrations(config, style, seed, episodes, backend, out,
                                        on_episode=lambda index, result: bar.update())
    decisions = sum(row["steps"] for row in metrics)
    collisions = sum(row["collisions"] for row in metrics)
    click.echo(f"wrote {out}: {episodes} episodes, {decisions} decisions, style {style}, {collisions} collisions")


@click.command("evaluate")
@config_options
@click.option("--policy", "policies", multiple=True, default=("expert",), show_default=True,
              metavar="expert[:STYLE]|keep|random|PATH",
              help="Driver to evaluate (repeatable: drivers side by side on the same seeds).")
@click.option("--style", type=_STYLE, default=DEFAULT_STYLE, show_default=True,
              help="Style of --policy expert (expert:STYLE picks one per driver).")
@episode_options(default_seed=1000, default_episodes=16)
@click.option("--gui/--gui-off", default=False, show_default=True,
              help="--gui drives the first episode of the first driver in sumo-gui (needs a display).")
@output_options(required=False)
def evaluate_command(config_path: Path | None, overrides: tuple[str, ...], policies: tuple[str, ...], style: str,
                     episodes: int, seed: int, workers: int, gui: bool, out: Path | None, overwrite: bool) -> None:
    """Evaluate drivers on held-out seeds; print the paper's metrics (mean +- std) and write one row per episode."""
    config = resolve_config(config_path, overrides)
    check_output(out, overwrite)
    from sumo_rail.backends import ProcessPoolBackend, SerialBackend
    from sumo_rail.evaluate import evaluate, parse_driver, summary_table, write_metrics
    from sumo_rail.policies import PolicyFileError
    from sumo_rail.seeding import Purpose, episode_seeds

    drivers = []
    for text in policies:
        try:
            drivers.append(parse_driver(text, config, style))
        except PolicyFileError as error:
            raise click.ClickException(str(error)) from error
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="'--policy'") from error
    if gui:
        drivers, episodes = drivers[:1], 1
    seeds = episode_seeds(Purpose.EVALUATE, seed, episodes)
    backend = SerialBackend(render_mode="human") if gui else ProcessPoolBackend(workers)
    with library_errors(), backend, episode_progress(len(drivers) * episodes, "evaluating") as bar:
        metrics = evaluate(drivers, config, seeds, backend, on_episode=lambda index, result: bar.update())
        if out is not None:
            write_metrics(metrics, config, seed, out, policies=list(policies), episode_seeds=seeds)
    click.echo(summary_table(metrics))
    if out is not None:
        click.echo(f"wrote {out}: {len(metrics)} episodes")
