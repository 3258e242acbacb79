"""Methods trained with several seeds, for the experiment tables: drivers are named METHOD_sSEED/POLICY.

A method's estimate pools its training runs' episodes; its interval (`statistics.seeded_interval`) adds the
spread between training runs to the episodes' noise, with Student's t over the runs (a share's kept within [0, 1],
`summary.SHARES`). A difference pairs runs seed
by seed (RAIL seed s started from BC seed s; between independently trained methods the seed label is an arbitrary
pairing) and episodes by their seed and warm state, which every driver shares. Each run's own estimate is shown
next to it.
"""

from __future__ import annotations

import re

import pandas as pd

from sumo_rail.evaluation.statistics import Interval, Sample, ratio, seeded_interval
from sumo_rail.evaluation.summary import SHARES, measure_samples


def training_seeds(metrics: pd.DataFrame, method: str) -> list[int]:
    """The training seeds of `method` found in an evaluation's driver names."""
    pattern = re.compile(rf"{re.escape(method)}_s(\d+)/")
    return sorted({int(found.group(1)) for name in metrics["policy"].unique() if (found := pattern.match(name))})


def seed_samples(metrics: pd.DataFrame, method: str, seeds: list[int], policy: str | None = None
                 ) -> list[dict[str, Sample]]:
    """Each seed's measure samples, episodes in evaluation-seed order (the same order for every driver). The
    driver is METHOD_sSEED/POLICY, or the one driver in METHOD_sSEED/ without `policy`."""
    found = []
    for seed in seeds:
        folder = f"{method}_s{seed}/"
        names = [name for name in metrics["policy"].unique()
                 if (name == folder + policy if policy is not None else name.startswith(folder))]
        if len(names) != 1:
            raise ValueError(f"expected one driver {folder}{policy or '...'} in the evaluation, found {names}")
        found.append(measure_samples(metrics[metrics["policy"] == names[0]].sort_values("seed")))
    return found


def pooled(per_seed: list[dict[str, Sample]], measure: str,
           references: list[dict[str, Sample]] | None = None) -> Interval:
    """`measure` over the training runs `per_seed` (minus `references`, paired seed by seed) with its interval
    (`statistics.seeded_interval`; a share's within its range)."""
    return seeded_interval([samples[measure] for samples in per_seed],
                           None if references is None else [samples[measure] for samples in references],
                           share=measure in SHARES)


def value_cell(per_seed: list[dict[str, Sample]], measure: str, digits: int) -> str:
    """'0.52 [0.40, 0.61] (per seed 0.50, 0.55, 0.51)'."""
    seeds = ", ".join(f"{ratio(samples[measure]):.{digits}f}" for samples in per_seed)
    found = pooled(per_seed, measure)
    return f"{found.format(digits)} (per seed {seeds})"


def per_seed_differences(per_seed: list[dict[str, Sample]], references: list[dict[str, Sample]],
                         measure: str) -> list[float]:
    """Point estimates of the difference for each training seed, paired seed by seed."""
    return [float(ratio(mine[measure]) - ratio(theirs[measure])) for mine, theirs in zip(per_seed, references,
                                                                                          strict=True)]


def difference_cell(per_seed: list[dict[str, Sample]], references: list[dict[str, Sample]], measure: str,
                    digits: int) -> str:
    """'+0.12 [+0.05, +0.20] higher (per seed +0.10, +0.15, +0.11)'."""
    found = pooled(per_seed, measure, references)
    seeds = ", ".join(f"{value:+.{digits}f}" for value in per_seed_differences(per_seed, references, measure))
    return f"{found.format(digits, signed=True)} {verdict(found)} (per seed {seeds})"


def verdict(found: Interval) -> str:
    return "higher" if found.low > 0 else "lower" if found.high < 0 else "no detectable difference"


def digits_of(measure: str) -> int:
    return 3 if "agreement" in measure or "lane_change_" in measure or measure.endswith("_share") else 2
