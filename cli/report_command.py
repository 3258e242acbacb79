"""The command `report`: training runs and evaluation metrics -> PNG plots and a Markdown summary."""

from __future__ import annotations

from pathlib import Path

import click
from sumo_rail_cli.options import library_errors


@click.command("report")
@click.argument("inputs", nargs=-1, required=True, metavar="RUN_OR_METRICS...",
                type=click.Path(exists=True, path_type=Path))
@click.option("--out", type=click.Path(path_type=Path, file_okay=False), required=True,
              help="Folder for report.md and the PNG plots (created; files in it with the same names are replaced).")
def report_command(inputs: tuple[Path, ...], out: Path) -> None:
    """Plot training runs (folders written by train) and evaluation metrics (files written by evaluate --out)."""
    from sumo_rail.report.inputs import ReportError, read_inputs
    from sumo_rail.report.markdown import write_report

    with library_errors():
        try:
            path = write_report(read_inputs(list(inputs)), out)
        except ReportError as error:
            raise click.ClickException(str(error)) from error
    click.echo(f"wrote the report to {path}")
