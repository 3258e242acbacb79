"""The recovery test's table and figure (experiments/recovery.py): per start condition and method, the share of
episodes in which the driver returned to the expert's behaviour within the horizon and the decisions it took
(censored at the horizon), pooled over training seeds with 95% intervals (`statistics.seeded_interval`; a share's
within [0, 1]), and each method's paired difference to the expert and DART's to BC, on the same episodes.

Usage: python experiments/recovery_table.py RECOVERY_DIR FIGURE.png   (prints Markdown)
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from seeded import verdict

from sumo_rail.evaluation.recovery import CONDITIONS
from sumo_rail.evaluation.statistics import Sample, mean_sample, seeded_interval

LABELS = {"expert": "expert", "bc_mlp": "BC", "rail_mlp": "RAIL", "dagger": "DAgger", "dart": "DART"}
MEASURES = {"recovered": ("recovered within the horizon", 3), "decisions_to_recover": ("decisions to recover", 1),
            "agreement": ("agreement while driving", 3)}
SHARES = {"recovered", "agreement"}
"""The measures that are shares, whose intervals stay within [0, 1] (`statistics.seeded_interval`'s `share`)."""
CONDITION_NAMES = {"low": "set-point too low", "high": "set-point too high", "left": "in a lane the expert would leave"}


def method_of(policy: str) -> str:
    """bc_mlp_s0/policy_bc -> bc_mlp; the expert (expert-STYLE) -> expert."""
    found = re.match(r"(.+)_s\d+/", policy)
    return found.group(1) if found else "expert"


def samples(frame: pd.DataFrame, method: str, condition: str, measure: str) -> list[Sample]:
    """One Sample per training run of `method`: its started episodes of `condition`, by seed."""
    rows = frame[(frame["method"] == method) & (frame["condition"] == condition) & frame["started"]]
    values = rows.sort_values("seed").groupby("policy", sort=True)[measure].apply(lambda v: v.to_numpy(float))
    return [mean_sample(np.nan_to_num(run, nan=0.0) if measure == "agreement" else run) for run in values]


def main(folder: Path, figure: Path) -> None:
    frame = pd.concat([pd.read_parquet(path) for path in sorted(folder.glob("*.parquet"))], ignore_index=True)
    frame["method"] = frame["policy"].map(method_of)
    methods = [method for method in LABELS if method in set(frame["method"])]
    started = frame[frame["method"] == "expert"].groupby("condition")["started"].agg(["sum", "size"])
    print("Episodes whose start was reached (the same for every driver) of those tried: "
          + ", ".join(f"{CONDITION_NAMES[c]} {started.loc[c, 'sum']} of {started.loc[c, 'size']}" for c in CONDITIONS
                      if c in started.index) + ".\n")
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for measure, (title, digits) in MEASURES.items():
        print(f"| {title} | " + " | ".join(f"{LABELS[m]} ({len(samples(frame, m, CONDITIONS[0], measure))})"
                                            for m in methods) + " |")
        print("|---|" + "---|" * len(methods))
        for condition in CONDITIONS:
            cells = [seeded_interval(samples(frame, method, condition, measure), share=measure in SHARES).format(digits)
                     for method in methods]
            print(f"| {CONDITION_NAMES[condition]} | " + " | ".join(cells) + " |")
        print()
    print("| condition | comparison | recovered within the horizon | decisions to recover |")
    print("|---|---|---|---|")
    for condition in CONDITIONS:
        expert = {measure: samples(frame, "expert", condition, measure)[0] for measure in MEASURES}
        pairs = [(method, "expert") for method in methods if method != "expert"] + [("dart", "bc_mlp")]
        for method, reference in pairs:
            if method not in methods or reference not in methods:
                continue
            cells = []
            for measure in ("recovered", "decisions_to_recover"):
                mine = samples(frame, method, condition, measure)
                theirs = (samples(frame, reference, condition, measure) if reference != "expert"
                          else [expert[measure]] * len(mine))
                found = seeded_interval(mine[:len(theirs)], theirs[:len(mine)], share=measure in SHARES)
                cells.append(f"{found.format(MEASURES[measure][1], signed=True)} {verdict(found)}")
            print(f"| {CONDITION_NAMES[condition]} | {LABELS[method]} - {LABELS[reference]} | " + " | ".join(cells)
                  + " |")
    width = 0.8 / len(methods)
    for axis, measure in zip(axes, ("recovered", "decisions_to_recover"), strict=True):
        for index, method in enumerate(methods):
            found = [seeded_interval(samples(frame, method, condition, measure), share=measure in SHARES)
                     for condition in CONDITIONS]
            x = np.arange(len(CONDITIONS)) + (index - (len(methods) - 1) / 2) * width
            axis.bar(x, [f.estimate for f in found], width, label=LABELS[method],
                     yerr=np.array([[f.estimate - f.low for f in found], [f.high - f.estimate for f in found]]),
                     capsize=2)
        axis.set_xticks(np.arange(len(CONDITIONS)), [CONDITION_NAMES[c] for c in CONDITIONS], fontsize=8)
        axis.set_title(MEASURES[measure][0])
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(figure, dpi=120)


@click.command(help=__doc__)
@click.argument("folder", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("figure", type=click.Path(dir_okay=False, path_type=Path))
def cli(folder: Path, figure: Path) -> None:
    main(folder, figure)


if __name__ == "__main__":
    cli()
