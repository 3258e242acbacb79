"""The generalisation table (specs/generalisation.toml): the expert on every road (its rows of each (a) file);
BC, DAgger, RAIL and GAIL (their rail_*.parquet and gail_*.parquet evaluations) trained and tested on each road (a),
trained on the straight road
and tested on the others and at densities it never saw (b), trained on a mix of roads (c), and trained without the
route block (d); each method pooled over its training seeds (experiments/seeded.py), with paired differences (b) - (a),
(c) - (a) and (d) - (a) on the same test episodes, the safety measures of (a) against the expert's, and RAIL against
BC, DAgger and GAIL on the same episodes. Prints
Markdown; writes the figure.

Usage: python experiments/generalisation_table.py OUT_DIR [FIGURE.png]
"""

from __future__ import annotations

from pathlib import Path

import click
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from seeded import difference_cell, pooled, training_seeds, value_cell

from sumo_rail.evaluation.statistics import Sample, interval, mean_sample
from sumo_rail.evaluation.summary import measure_samples

KINDS = ("straight", "merge", "merge_from_ramp", "lane_drop", "exit")
METHODS = {"BC": ("dagger", "policy_bc"), "DAgger": ("dagger", "policy_latest"), "RAIL": ("rail", "policy_latest"),
           "GAIL": ("gail", "policy_latest")}
MIX = {"BC, mixed roads": ("dagger", "policy_bc"), "DAgger, mixed roads": ("dagger", "policy_latest"),
       "RAIL, mixed roads": ("rail", "policy_latest")}
NO_ROUTE = {"BC": ("no_route", "policy_bc"), "DAgger": ("no_route", "policy_latest")}
SHOWN = ("agreement", "average_speed_kmh", "lane_changes", "failures", "merges")
PLOTTED = ("agreement", "failures")
LABELS = {"agreement": "agreement", "average_speed_kmh": "speed [km/h]", "lane_changes": "lane changes",
          "failures": "failed episodes", "merges": "merges"}
SAFETY_SHOWN = {"min_ttc_s": "least TTC [s]", "ttc_below_1_5s_share": "decisions with TTC < 1.5 s",
                "cut_ins": "cut-ins", "hard_braking": "hard braking", "collisions": "collisions"}
"""The safety measures of docs/safety.md shown for each road's (a) drivers, and their columns' labels."""
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
    """The evaluation `name`, with RAIL's and GAIL's evaluations of the same episodes (rail_NAME, gail_NAME) where
    there are."""
    frames = [pd.read_parquet(path) for path in (out / f"{prefix}{name}.parquet" for prefix in ("", "rail_", "gail_"))
              if path.exists()]
    return pd.concat(frames).drop_duplicates(["policy", "seed"]) if frames else None


def rail_comparisons(out: Path) -> list[str]:
    """RAIL minus BC, DAgger and GAIL, paired by training seed and episode, wherever RAIL was evaluated ((a), (b)
    and (c) evaluations, with their rail_ part; in (c) each method trained on the mix; GAIL in (a) only)."""
    others = " | ".join(f"RAIL - {other}: agreement / failed episodes" for other in ("BC", "DAgger", "GAIL"))
    lines = [f"| tested on | trained on | {others} |", "|---|---|---|---|---|"]
    stems = {path.stem.removeprefix("rail_").removeprefix("gail_") for path in out.glob("*.parquet")
             if "decisions" not in path.name}
    names = sorted(stem for stem in stems if stem.startswith(("a_", "b_", "c_")))
    for name in names:
        metrics = read(out, name)
        rail = per_seed(metrics, "rail", "policy_latest")
        if not rail:
            continue
        cells = []
        for method, policy in (METHODS["BC"], METHODS["DAgger"], METHODS["GAIL"]):
            theirs = per_seed(metrics, method, policy)
            cells.append(" / ".join(difference_cell(rail, theirs, measure, 3 if measure == "agreement" else 2)
                                    for measure in ("agreement", "failures")) if len(theirs) == len(rail) else "-")
        condition, _, road = name.partition("_")
        trained_on = {"a": f"(a) {road}", "b": "(b) straight", "c": "(c) every road"}[condition]
        lines.append(f"| {road} | {trained_on} | " + " | ".join(cells) + " |")
    return lines


def expert_table(out: Path) -> list[str]:
    lines = ["| road | episodes | " + " | ".join(EXPERT_MEASURES) + " |", "|---|---|" + "---|" * len(EXPERT_MEASURES)]
    for kind in KINDS:
        own = read(out, f"a_{kind}")  # the expert drives each road's test episodes in its (a) evaluation
        metrics = None if own is None else own[own["policy"].str.startswith("expert-")]
        if metrics is None or metrics.empty:
            continue
        found = samples(metrics)
        cells = [interval(found[name]).format(2) if name in found else "-" for name in EXPERT_MEASURES]
        lines.append(f"| {kind} | {len(metrics)} | " + " | ".join(cells) + " |")
    return lines


def safety_table(out: Path) -> list[str]:
    """The expert's and each method's (a) drivers' safety measures on every road, with each method minus the expert
    on the same test episodes (least TTC, cut-ins and hard braking)."""
    lines = ["| road | driver | " + " | ".join(SAFETY_SHOWN.values())
             + " | minus the expert: least TTC / cut-ins / hard braking |",
             "|---|---|" + "---|" * (len(SAFETY_SHOWN) + 1)]
    for kind in KINDS:
        own = read(out, f"a_{kind}")
        experts = None if own is None else own[own["policy"].str.startswith("expert-")]
        if experts is None or experts.empty:
            continue
        expert = samples(experts)
        lines.append(f"| {kind} | expert | " + " | ".join(interval(expert[name]).format(3 if "share" in name else 2)
                                                          for name in SAFETY_SHOWN) + " | - |")
        for label, (method, policy) in METHODS.items():
            mine = per_seed(own, method, policy)
            if mine:
                cells = [value_cell(mine, name, 3 if "share" in name else 2) for name in SAFETY_SHOWN]
                difference = " / ".join(difference_cell(mine, [expert] * len(mine), name, 2)
                                        for name in ("min_ttc_s", "cut_ins", "hard_braking"))
                lines.append(f"| {kind} | {label} | " + " | ".join(cells) + f" | {difference} |")
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
            ref_method, ref_policy = reference_methods[label.split(",")[0]]  # "DAgger, mixed roads": DAgger's
            theirs = per_seed(reference, ref_method, ref_policy)
            if len(theirs) == len(mine):
                difference = " / ".join(difference_cell(mine, theirs, name, 3 if name == "agreement" else 2)
                                        for name in ("agreement", "failures"))
        for measure in PLOTTED:
            found = pooled(mine, measure)
            figure[(road, f"{label}, {trained_on.split(' ', 1)[0]}", measure)] = (found.estimate, found.low, found.high)
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
        metrics = read(out, name)
        flow = name.rsplit("_", 1)[1]
        lines += method_rows(metrics, None, f"straight at {flow} veh/h", "(b) straight at 4000", METHODS, METHODS,
                             figure)
        expert = samples(metrics[metrics["policy"].str.startswith("expert-")])
        lines.append(f"| straight at {flow} veh/h | expert | - | 1 | "
                     + " | ".join(interval(expert[n]).format(2) for n in SHOWN[1:]) + " | - |")
    return lines


CONDITIONS = (("(a)", "trained there (a)"), ("(b)", "on the straight road only (b)"), ("(c)", "on every road (c)"),
              ("(d)", "without the route block (d)"))
"""The training conditions a figure's title names, each when the figure has it."""


def plot(figure: dict[tuple[str, str, str], tuple[float, float, float]], path: Path) -> None:
    """Agreement and failed episodes per road, one bar per method and training condition, with 95% intervals."""
    roads = list(dict.fromkeys(road for road, _, _ in figure))
    series = list(dict.fromkeys(name for _, name, _ in figure))
    fig, axes = plt.subplots(2, 1, figsize=(12, 8), sharex=True)
    width = 0.8 / max(len(series), 1)
    colours = plt.get_cmap("tab20")  # one colour per series: the default cycle repeats after 10
    for axis, measure in zip(axes, PLOTTED, strict=True):
        for index, name in enumerate(series):
            points = [(position, figure[(road, name, measure)]) for position, road in enumerate(roads)
                      if (road, name, measure) in figure]
            if not points:
                continue
            x = np.array([position for position, _ in points]) + (index - (len(series) - 1) / 2) * width
            values = np.array([value for _, value in points])
            errors = np.clip(np.stack([values[:, 0] - values[:, 1], values[:, 2] - values[:, 0]]), 0, None)
            axis.bar(x, values[:, 0], width, yerr=errors, capsize=2, label=name, color=colours(index % colours.N))
        axis.set_ylabel(LABELS[measure])
        axis.set_ylim(0, 1)
    axes[0].legend(fontsize=8, ncol=5, loc="lower center", bbox_to_anchor=(0.5, 1.08))
    axes[1].set_xticks(range(len(roads)), roads, rotation=10)
    conditions = [words for tag, words in CONDITIONS if any(name.endswith(f", {tag}") for name in series)]
    axes[0].set_title(f"Each road: {', '.join(conditions)}; 95% intervals over 3 training seeds")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(out: Path, figure_path: Path | None) -> None:
    print("### The expert on every road\n")
    print("\n".join(expert_table(out)))
    figure: dict[tuple[str, str, str], tuple[float, float, float]] = {}
    print("\n### Learned drivers on roads they saw and never saw\n")
    print("\n".join(generalisation_table(out, figure)))
    print("\n### Safety on every road (a)\n")
    print("\n".join(safety_table(out)))
    comparisons = rail_comparisons(out)
    if len(comparisons) > 2:
        print("\n### RAIL against BC, DAgger and GAIL on the same episodes\n")
        print("\n".join(comparisons))
    if figure_path is not None and figure:
        plot(figure, figure_path)
        print(f"\n(figure: {figure_path})")


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("figure_path", required=False, type=click.Path(dir_okay=False, path_type=Path))
def cli(out: Path, figure_path: Path | None) -> None:
    main(out, figure_path)


if __name__ == "__main__":
    cli()
