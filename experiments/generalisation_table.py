"""The generalisation table (experiments/generalisation.sh): the expert on every road; BC and DAgger trained and tested
on each road (a), trained on the straight road and tested on the others and at densities it never saw (b), BC
trained on a mix of roads (c), and trained without the route block (d); each method pooled over its training seeds
(experiments/seeded.py), with paired differences (b) - (a), (c) - (a) and (d) - (a) on the same test episodes.
Prints Markdown; writes the figure.

Usage: python experiments/generalisation_table.py OUT_DIR [FIGURE.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from seeded import difference_cell, training_seeds, value_cell

from sumo_rail.evaluation.statistics import Sample, interval, mean_sample, seeded_interval
from sumo_rail.evaluation.summary import measure_samples

KINDS = ("straight", "merge", "merge_from_ramp", "lane_drop", "exit")
METHODS = {"BC": ("dagger", "policy_bc"), "DAgger": ("dagger", "policy_latest")}
MIX = {"BC, mixed roads": ("bc", "policy_bc")}
NO_ROUTE = {"BC": ("no_route", "policy_bc"), "DAgger": ("no_route", "policy_latest")}
SHOWN = ("agreement", "average_speed_kmh", "lane_changes", "failures", "merges")
LABELS = {"agreement": "agreement", "average_speed_kmh": "speed [km/h]", "lane_changes": "lane changes",
          "failures": "failed episodes", "merges": "merges"}
EXPERT_MEASURES = ("average_speed_kmh", "overtakes", "lane_changes", "collisions", "teleports", "merges",
                   "seconds_per_merge", "missed_exits", "lane_end_stops", "failures")


def samples(frame: pd.DataFrame) -> dict[str, Sample]:
    """`measure_samples` with the route's measures on every road (failures: a collision, missed exit or lane-end
    stop; merges) and teleports."""
    frame = frame.sort_values("seed")
    found = measure_samples(frame)
    stops = frame["missed_exits"].to_numpy() + frame["lane_end_stops"].to_numpy()
    found["failures"] = mean_sample(((frame["collisions"].to_numpy() > 0) | (stops > 0)).astype(float))
    for name in ("merges", "missed_exits", "lane_end_stops", "teleports"):
        found[name] = mean_sample(frame[name].to_numpy().astype(float))
    if frame["merges"].any():
        found["seconds_per_merge"] = (frame["merge_time_s"].to_numpy(), frame["merges"].to_numpy().astype(float))
    return found


def per_seed(metrics: pd.DataFrame, method: str, policy: str) -> list[dict[str, Sample]]:
    seeds = training_seeds(metrics, method)
    names = [f"{method}_s{seed}/{policy}" for seed in seeds]
    return [samples(metrics[metrics["policy"] == name]) for name in names] if all(
        name in set(metrics["policy"]) for name in names) else []


def read(out: Path, name: str) -> pd.DataFrame | None:
    path = out / f"{name}.parquet"
    return pd.read_parquet(path) if path.exists() else None


def expert_table(out: Path) -> list[str]:
    lines = ["| road | episodes | " + " | ".join(EXPERT_MEASURES) + " |", "|---|---|" + "---|" * len(EXPERT_MEASURES)]
    for kind in KINDS:
        metrics = read(out, f"expert_{kind}")
        if metrics is None:
            continue
        found = samples(metrics)
        cells = [interval(found[name]).format(2) if name in found else "-" for name in EXPERT_MEASURES]
        lines.append(f"| {kind} | {len(metrics)} | " + " | ".join(cells) + " |")
    return lines


def method_rows(metrics: pd.DataFrame, reference: pd.DataFrame | None, road: str, trained_on: str,
                methods: dict[str, tuple[str, str]], reference_methods: dict[str, tuple[str, str]],
                figure: dict[tuple[str, str, str], tuple[float, float, float]]) -> list[str]:
    """One row per method: its measures pooled over seeds and, with `reference`, its paired difference to the same
    method's (a) runs (`reference_methods`' policies) on the same test episodes."""
    rows = []
    for label, (method, policy) in methods.items():
        mine = per_seed(metrics, method, policy)
        if not mine:
            continue
        cells = [value_cell(mine, name, 3 if name == "agreement" else 2) for name in SHOWN]
        difference = ""
        if reference is not None:
            ref_method, ref_policy = reference_methods.get(label, reference_methods["BC"])
            theirs = per_seed(reference, ref_method, ref_policy)
            if len(theirs) == len(mine):
                difference = " / ".join(difference_cell(mine, theirs, name, 3 if name == "agreement" else 2)
                                        for name in ("agreement", "failures"))
        found = seeded_interval([seed["agreement"] for seed in mine])
        figure[(road, label, trained_on)] = (found.estimate, found.low, found.high)
        rows.append(f"| {road} | {label} | {trained_on} | " + " | ".join(cells) + f" | {difference or '-'} |")
    return rows


def generalisation_table(out: Path, figure: dict[tuple[str, str, str], tuple[float, float, float]]) -> list[str]:
    header = ("| tested on | method | trained on | " + " | ".join(LABELS[name] for name in SHOWN)
              + " | difference to (a): agreement / failed episodes |")
    lines = [header, "|---|---|---|" + "---|" * (len(SHOWN) + 1)]
    for kind in KINDS:
        own = read(out, f"a_{kind}")
        if own is not None:
            lines += method_rows(own, None, kind, f"(a) {kind}", METHODS, METHODS, figure)
        straight = read(out, f"b_{kind}")
        if straight is not None:
            lines += method_rows(straight, own, kind, "(b) straight", METHODS, METHODS, figure)
        mixed = read(out, f"c_{kind}")
        if mixed is not None:
            lines += method_rows(mixed, own, kind, "(c) every road", MIX, METHODS, figure)
        blind = read(out, f"d_{kind}")
        if blind is not None:
            lines += method_rows(blind, own, kind, f"(d) {kind}, no route block", NO_ROUTE, METHODS, figure)
    for name in sorted(path.stem for path in out.glob("b_straight_*.parquet") if "decisions" not in path.name):
        metrics = pd.read_parquet(out / f"{name}.parquet")
        flow = name.rsplit("_", 1)[1]
        lines += method_rows(metrics, None, f"straight at {flow} veh/h", "(b) straight at 4000", METHODS, METHODS,
                             figure)
        expert = samples(metrics[metrics["policy"].str.startswith("expert-")])
        lines.append(f"| straight at {flow} veh/h | expert | - | 1 | "
                     + " | ".join(interval(expert[n]).format(2) for n in SHOWN[1:]) + " | - |")
    return lines


def plot(figure: dict[tuple[str, str, str], tuple[float, float, float]], path: Path) -> None:
    roads = list(dict.fromkeys(road for road, _, _ in figure))
    series = list(dict.fromkeys((label, trained) for _, label, trained in figure))
    fig, axis = plt.subplots(figsize=(12, 4.5))
    width = 0.8 / max(len(series), 1)
    for index, (label, trained) in enumerate(series):
        points = [(position, figure[(road, label, t)]) for position, road in enumerate(roads)
                  for lab, t in [(label, trained)] if (road, lab, t) in figure]
        if not points:
            continue
        x = np.array([position for position, _ in points]) + (index - (len(series) - 1) / 2) * width
        estimate = np.array([value[0] for _, value in points])
        errors = np.array([[value[0] - value[1] for _, value in points], [value[2] - value[0] for _, value in points]])
        axis.bar(x, estimate, width, yerr=errors, capsize=2, label=f"{label}, {trained.split(' ', 1)[0]} "
                                                                   f"{trained.split(' ', 1)[1].split(' at')[0]}")
    axis.set_xticks(range(len(roads)), roads, rotation=15)
    axis.set_ylabel("agreement with the expert")
    axis.set_ylim(0, 1)
    axis.legend(fontsize=8, ncol=3)
    axis.set_title("Agreement on each road: trained there (a), on the straight road only (b), on a mix (c); 95% CI")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(out: Path, figure_path: Path | None) -> None:
    print("### The expert on every road\n")
    print("\n".join(expert_table(out)))
    figure: dict[tuple[str, str, str], tuple[float, float, float]] = {}
    print("\n### Learned drivers on roads they saw and never saw\n")
    print("\n".join(generalisation_table(out, figure)))
    if figure_path is not None and figure:
        plot(figure, figure_path)
        print(f"\n(figure: {figure_path})")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else None)
