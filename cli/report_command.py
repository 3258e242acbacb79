"""The command `report`: training runs and evaluation metrics -> PNG plots and a Markdown summary."""

from __future__ import annotations

from pathlib import Path

import click

from .output_lock import lock_output
from .running import library_errors


@click.command("report")
@click.argument("inputs", nargs=-1, required=True, metavar="RUN_OR_METRICS...",
                type=click.Path(exists=True, path_type=Path))
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Folder for report.md and the PNG plots (created; files in it with the same names are replaced).")
@click.option("--videos", type=click.Path(exists=True, file_okay=False, path_type=Path), default=None,
              help="Folder written by evaluate --video: adds GIFs of each driver above the expert on the same seed "
                   "(needs pip install 'sumo-rail[video]').")
def report_command(inputs: tuple[Path, ...], out: Path, videos: Path | None) -> None:
    """Plot training runs (folders written by train, dagger, gail or ppo) and evaluation metrics (files written by
    evaluate --out)."""
    from sumo_rail.report.inputs import ReportError, read_inputs
    from sumo_rail.report.markdown import write_report

    lock_output(out)  # one command at a time writes a report folder
    with library_errors():
        try:
            path = write_report(read_inputs(list(inputs)), out, videos)
        except ReportError as error:
            raise click.ClickException(str(error)) from error
    click.echo(f"wrote the report to {path}")
