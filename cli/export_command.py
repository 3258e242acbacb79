"""The command `export-minari`: recorded demonstrations -> a Minari offline dataset."""

from __future__ import annotations

from pathlib import Path

import click

from .output_lock import lock_output
from .progress import progress
from .running import library_errors


@click.command("export-minari")
@click.argument("demos", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--name", "dataset_id", required=True, metavar="[NAMESPACE/]NAME-vN",
              help="Minari dataset id, e.g. sumo-rail/expert-normal-v0 (load it with minari.load_dataset).")
@click.option("--root", type=click.Path(path_type=Path, file_okay=False), default=None,
              help="Minari's datasets folder  [default: $MINARI_DATASETS_PATH, else ~/.minari/datasets].")
@click.option("--overwrite", is_flag=True, help="Replace a dataset with the same id.")
def export_minari_command(demos: Path, dataset_id: str, root: Path | None, overwrite: bool) -> None:
    """Export demonstrations written by record-expert to Minari, the Farama format for offline datasets.

    Each episode's observation after its last decision is recovered by replaying it from its seed (the replay
    checks it reproduces every recorded observation). Needs pip install 'sumo-rail[minari]'."""
    from sumo_rail.runners.minari_export import ExportError, export_minari, read_episodes

    with library_errors():
        episodes = len(read_episodes(demos)[1])
        try:
            with progress(episodes, "replaying") as bar:
                summary = export_minari(demos, dataset_id, root, overwrite, on_episode=lambda index: bar.update(),
                                        hold=lock_output)
        except ExportError as error:
            raise click.ClickException(str(error)) from error
    click.echo(f"wrote Minari dataset {summary.dataset_id} to {summary.path}: {summary.episodes} episodes, "
               f"{summary.steps} steps")
