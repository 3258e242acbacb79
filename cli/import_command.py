"""The command `import-recording`: a recording of a format of the registry (`sumo_rail.recordings.formats`: highD,
NGSIM, SUMO FCD) -> a scene folder."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import click

from sumo_rail.recordings.formats import importable, taking, values

from .output_lock import lock_output
from .param_types import FiniteFloat
from .settings import config_options

if TYPE_CHECKING:
    from sumo_rail.config import Config


def _section(value: str | None) -> tuple[float, float] | None:
    if value is None:
        return None
    try:
        start, end = (float(part) for part in value.split(":"))
    except ValueError:
        raise click.BadParameter(f"expected START:END in metres, e.g. 50:400, got {value!r}",
                                 param_hint="--section") from None
    return start, end


def _vehicles(value: str | None) -> tuple[str, ...]:
    """Comma-separated ids; A-B (whole numbers, A <= B) is every id from A to B; None is every vehicle (())."""
    found: list[str] = []
    for part in (value or "").split(","):
        part = part.strip()
        low, dash, high = part.partition("-")
        if dash and low.isdigit() and high.isdigit():
            if int(low) > int(high):
                raise click.BadParameter(f"the range {part} is empty: write it from the lower id to the higher, "
                                         f"{high}-{low}", param_hint="--vehicles")
            found += [str(number) for number in range(int(low), int(high) + 1)]
        elif part:
            found.append(part)
    if value is not None and not found:
        raise click.BadParameter(f"{value!r} names no vehicle; leave --vehicles out to keep every vehicle",
                                 param_hint="--vehicles")
    return tuple(found)


def split_options(command: Callable[..., None]) -> Callable[..., None]:
    """The options of a scene's split by vehicle (import-recording, record-sumo-drivers)."""
    for option in reversed((
            click.option("--split-seed", type=click.IntRange(min=0), default=0, show_default=True,
                         help="Seed of the split by vehicle."),
            click.option("--test-share", type=FiniteFloat(0, 1, max_open=True), default=0.2, show_default=True,
                         help="Share of vehicles held out to test."),
            click.option("--validation-share", type=FiniteFloat(0, 1, max_open=True), default=0.1,
                         show_default=True, help="Share of vehicles kept for validation."))):
        command = option(command)
    return command


@click.command("import-recording")
@config_options
@click.option("--format", "format_", type=click.Choice([form.name for form in importable()]), required=True,
              help="; ".join(f"{form.name}: {form.files}" for form in importable()) + ".")
@click.argument("files", nargs=-1, required=True, type=click.Path(path_type=Path, dir_okay=False))
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="The scene folder to write (tracks.parquet, scene.json, road.net.xml, split.parquet).")
@click.option("--direction", type=click.Choice(values("direction")), default=None,
              help="highD: the driving direction to keep (the other is left out), or both (each on its own "
                   "carriageway)  [default: lower].")
@click.option("--site", type=click.Choice(values("site")), default=None,
              help="NGSIM: the site, which fixes the main lanes (US-101: 1-5, I-80: 1-6)  [default: us-101].")
@click.option("--period", type=click.IntRange(min=1), default=None, metavar="N",
              help="NGSIM: the recording period to import (1: the earliest) from files that hold several, as the "
                   "data.transportation.gov edition does (the command names them when one must be chosen).")
@click.option("--network", type=click.Path(path_type=Path, dir_okay=False), default=None,
              help="FCD: the SUMO .net.xml (or .net.xml.gz) the recording was driven on (any SUMO network).")
@click.option("--vtypes", type=click.Path(path_type=Path, dir_okay=False), default=None,
              help="FCD: the route or additional file defining the recording's vTypes (the reactive replay drives "
                   "each vehicle by its own; without it, by the IDM calibrated on the train split).")
@click.option("--vehicles", default=None, metavar="IDS", help="Keep only these source ids: 3,17,20-40.")
@click.option("--section", default=None, metavar="START:END", help="Keep only the rows whose front x lies in "
              "START..END m (scene coordinates: along the road in the driving direction for highD and NGSIM).")
@split_options
@click.option("--hold-out-after", "hold_out_after_s", type=FiniteFloat(min=0), default=None, metavar="T",
              help="Split by time instead: vehicles entering at or after T s are the test set.")
@click.option("--overwrite", is_flag=True, help="Replace a scene already in --out.")
def import_recording_command(config: Config, format_: str, files: tuple[Path, ...], out: Path, direction: str | None,
                             site: str | None, period: int | None, network: Path | None, vtypes: Path | None,
                             vehicles: str | None, section: str | None,
                             split_seed: int, test_share: float, validation_share: float,
                             hold_out_after_s: float | None, overwrite: bool) -> None:
    """Import a recording of real (or SUMO) driving as a scene: its tracks in the coordinates of a SUMO road.

    highD and NGSIM get a road built with netconvert from their lanes (NGSIM's with a ramp lane where vehicles use a
    ramp); FCD keeps the user's network. The
    command prints how many tracks it kept and why any were dropped (too short for one decision of
    env.decision_period_s, a gap in frames); docs/recordings.md has the details."""
    from sumo_rail.datasets import DatasetError
    from sumo_rail.recordings.importing import ImportSettings, check_import, import_recording
    from sumo_rail.recordings.scene import check_scene_output
    from sumo_rail.recordings.tracks import RecordingUsageError

    for option, value in (("direction", direction), ("site", site)):
        takers = [form.name for form in taking(option)]
        if value is not None and format_ not in takers:
            raise click.UsageError(f"--{option} applies to --format {' or '.join(takers)} only")
    settings = ImportSettings(format_, files, out, direction or "lower", site or "us-101", period, network,
                              _vehicles(vehicles), _section(section), split_seed, test_share, validation_share,
                              hold_out_after_s, overwrite, vtypes)
    try:
        options = check_import(settings)
        lock_output(out)  # held until the command ends: a second import into --out meanwhile is one sentence
        check_scene_output(out, overwrite)  # again, now that it is held: another import may have ended meanwhile
    except RecordingUsageError as error:
        raise click.UsageError(str(error)) from error
    try:
        summary = import_recording(settings, config, options)
    except DatasetError as error:
        raise click.ClickException(str(error)) from error
    for note in summary.notes:
        click.echo(f"note: {note}")
    reasons: dict[str, int] = {}
    for reason in summary.dropped.values():
        reasons[reason] = reasons.get(reason, 0) + 1
    dropped = "; ".join(f"{count} {reason}" for reason, count in sorted(reasons.items()))
    click.echo(f"kept {summary.kept} tracks, dropped {len(summary.dropped)}{f' ({dropped})' if dropped else ''}")
    click.echo("split: " + ", ".join(f"{count} {name}" for name, count in summary.split_counts.items()))
    click.echo(f"wrote the scene to {out}")
