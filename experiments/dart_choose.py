"""The DART noise level chosen on validation episodes (specs/dart.toml): the level whose BC agrees most with the
expert on the validation episodes (ties: the smaller level). Prints each level's agreement, then the chosen level.

Usage: python experiments/dart_choose.py OUT_DIR   (reads OUT_DIR/validation_epsLEVEL.parquet)
"""

from __future__ import annotations

import sys
from pathlib import Path

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


if __name__ == "__main__":
    main(Path(sys.argv[1]))
