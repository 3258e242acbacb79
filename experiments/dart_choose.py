"""The DART noise level chosen on validation episodes (specs/dart.toml): the level whose BC agrees most with the
expert on the validation episodes (ties: the smaller level). Prints each level's agreement, then the chosen level.

Usage: python experiments/dart_choose.py OUT_DIR   (reads OUT_DIR/validation_epsLEVEL.parquet)
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd

from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS, agreement_counts


def validation_agreement(path: Path) -> float:
    """Agreement with the expert pooled over an evaluation's decisions."""
    counts = agreement_counts(pd.read_parquet(path)[list(CONFUSION_COLUMNS)].to_numpy().reshape(-1, 5, 5))
    return float(counts["agreements"].sum() / counts["decisions"].sum())


def main(out: Path) -> None:
    levels = {path.stem.removeprefix("validation_eps"): validation_agreement(path)
              for path in out.glob("validation_eps*.parquet") if not path.name.endswith(".decisions.parquet")}
    if not levels:
        raise SystemExit(f"no validation_epsLEVEL.parquet in {out}")
    for level, agreement in sorted(levels.items(), key=lambda item: float(item[0])):
        print(f"epsilon {level}: validation agreement {agreement:.4f}")
    print(max(sorted(levels, key=float), key=lambda level: levels[level]))


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
def cli(out: Path) -> None:
    main(out)


if __name__ == "__main__":
    cli()
