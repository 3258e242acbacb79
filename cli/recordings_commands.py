"""The commands `record-sumo-drivers` (a scene of SUMO's own drivers) and `recorded-demos` (a scene's tracks as
demonstrations)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sumo_rail.config import ScenarioConfig

from .import_command import split_options
from .options import check_output
from .output_lock import lock_output
from .param_types import FiniteFloat, setting_range
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config


@click.command("record-sumo-drivers")
@config_options
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="The scene folder to write (tracks.parquet, scene.json, road.net.xml, split.parquet).")
@click.option("--seed", type=setting_range(ScenarioConfig, "traffic_seed"), required=True,
              help="SUMO's traffic seed (the range of scenario.traffic_seed).")
@click.option("--duration-s", type=FiniteFloat(1, 3600), default=600.0, show_default=True,
              help="Recorded time after the warm-up (scenario.warmup_s) [s].")
@split_options
@click.option("--overwrite", is_flag=True, help="Replace a scene already in --out.")
def record_sumo_drivers_command(config: Config, out: Path, seed: int, duration_s: float, split_seed: int,
                                test_share: float, validation_share: float, overwrite: bool) -> None:
    """Record SUMO's own drivers (Krauss and IDM, LC2013 with several temperaments, cars and trucks) on a straight
    motorway, or on your network (scenario.kind network: flows from every entry edge to scenario.route's end), as a
    scene folder: drivers whose rules no one here wrote.

    The road has scenario.lanes lanes of scenario.lane_width_m over scenario.length_m, and a speed limit of 44.44 m/s
    (160 km/h) as every scene road built from a recording (scenario.speed_limit_mps does not change it; the commands
    on the scene require it). The traffic arrives at scenario.flow_veh_per_h and is recorded after scenario.warmup_s
    (set with --set); every vehicle is captured at every SUMO step. The default 600 s at the default flow gives over
    500 tracks (about 700 per seed). The same seed and settings give the same files, byte for byte."""
    from sumo_rail.datasets import DatasetError
    from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, check_recording, record_sumo_drivers
    from sumo_rail.recordings.tracks import RecordingUsageError

    settings = SumoDriversSettings(out, seed, duration_s, split_seed, test_share, validation_share, overwrite)
    try:
        check_recording(settings, config)
    except RecordingUsageError as error:
        raise click.UsageError(str(error)) from error
    lock_output(out)
    try:
        summary = record_sumo_drivers(settings, config)
    except DatasetError as error:
        raise click.ClickException(str(error)) from error
    click.echo(f"recorded {summary.tracks} tracks ({summary.rows} rows at every "
               f"{config.scenario.step_length_s:g} s step), dropped {summary.dropped} too short or broken")
    click.echo("drivers: " + ", ".join(f"{count} {name}" for name, count in summary.types.items()))
    click.echo("split: " + ", ".join(f"{count} {name}" for name, count in summary.split_counts.items()))
    click.echo(f"wrote the scene to {out}")


@click.command("recorded-demos")
@config_options
@click.argument("scene", type=click.Path(path_type=Path, file_okay=False))
@click.option("--out", type=click.Path(path_type=Path, dir_okay=False), required=True,
              help="The demonstrations file to write (Parquet, record-expert's schema).")
@click.option("--split", type=click.Choice(["train", "validation", "test"]), default="train", show_default=True,
              help="Whose tracks: the scene's vehicles of this split.")
@click.option("--overwrite", is_flag=True, help="Replace --out if it exists.")
def recorded_demos_command(config: Config, scene: Path, out: Path, split: str, overwrite: bool) -> None:
    """Read a scene's tracks as demonstrations: one row per decision instant of each track of --split, the
    observation the env would give that vehicle there (computed from the scene's vehicles at that instant) and the
    action the reading rule reads (docs/recordings.md). train (BC, RAIL) and gail take the file as it is; DAgger
    refuses it, as a recorded driver cannot be asked what it would do elsewhere."""
    from sumo_rail.datasets import DatasetError
    from sumo_rail.recordings.recorded_demos import write_recorded_demos
    from sumo_rail.recordings.tracks import RecordingUsageError
    from sumo_rail.sim.actions import Action, paper_action

    check_output(out, overwrite)
    try:
        summary = write_recorded_demos(scene, config, split, out)
    except RecordingUsageError as error:
        raise click.UsageError(str(error)) from error
    except DatasetError as error:
        raise click.ClickException(str(error)) from error
    as_paper: Counter[Action] = Counter()  # an acceleration-interface action counted as the paper action it amounts to
    for action, count in summary.action_counts.items():
        as_paper[paper_action(action, config.actions)] += count
    counts = ", ".join(f"{as_paper[action]} {action.name.lower()}" for action in Action)
    if config.actions.interface == "acceleration":
        counts += " (a lane change, else the sign of the period's acceleration)"
    skipped = f", skipped {summary.skipped} shorter than one decision" if summary.skipped else ""
    click.echo(f"read {summary.decisions} decisions of {summary.tracks} tracks ({split}){skipped}")
    click.echo(f"actions: {counts}")
    click.echo(f"wrote {out}")
