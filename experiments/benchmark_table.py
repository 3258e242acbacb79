"""The benchmark's tables (experiments/specs/imitation_table.toml): every method pooled over its training seeds on the
same test episodes, its difference to the expert, the paired differences between methods, the training budget
and the distribution distances to the expert. Seeds are pooled as experiments/seeded.py says. Prints Markdown.

Usage: python experiments/benchmark_table.py OUT_DIR [--summary]
(reads OUT_DIR/test_sSEED.parquet and the run folders, and the per-decision records beside the evaluations or, where
they are not committed, OUT_DIR/distributions.parquet, the summary of them the table reads; --summary writes it)
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
from seeded import difference_cell, digits_of, pooled, seed_samples, training_seeds, value_cell

from sumo_rail.datasets import read_metadata
from sumo_rail.evaluation.distributions import decision_summary, summary_distances
from sumo_rail.evaluation.evaluate import decisions_path
from sumo_rail.evaluation.statistics import Sample, interval
from sumo_rail.evaluation.summary import distance_text, measure_samples
from sumo_rail.runners.experts import SAMPLED_SUFFIX

METHODS = {  # key: (label, run folder stem, policy in it)
    "bc_mlp": ("BC, two-layer", "bc_mlp", "policy_bc"),
    "rail_mlp": ("RAIL, two-layer", "rail_mlp", "policy_latest"),
    "bc_linear": ("BC, linear", "bc_linear", "policy_bc"),
    "rail_linear": ("RAIL, linear", "rail_linear", "policy_latest"),
    "dagger": ("DAgger, two-layer", "dagger", "policy_latest"),
    "gail": ("GAIL, two-layer, argmax", "gail", "policy_latest"),
    "gail_sampled": ("GAIL, two-layer, sampled", "gail", f"policy_latest{SAMPLED_SUFFIX}"),
}
COMPARISONS = (("rail_mlp", "bc_mlp"), ("rail_linear", "bc_linear"), ("rail_mlp", "dagger"), ("rail_mlp", "gail"),
               ("rail_mlp", "gail_sampled"), ("dagger", "bc_mlp"))
SUMMARY = "distributions.parquet"
"""The decision summary of all test evaluations pooled (the expert once), committed in place of their records."""
DERIVED = (".decisions.parquet", ".distributions.parquet", ".setpoints.parquet")
"""Files beside an evaluation NAME.parquet that are not metrics: its records and the summaries of them."""
HEADLINE = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
            "lane_changes", "collisions")
MEASURES = ("agreement", "lane_change_recall", "lane_change_precision", "lateral_agreement", "longitudinal_agreement",
            "average_speed_kmh", "overtakes", "lane_changes", "collisions")


def expert_driver(metrics: pd.DataFrame) -> str:
    """The expert's name among an evaluation's drivers: expert-STYLE (rule-based) or expert-NAME (a policy file)."""
    experts = sorted({name for name in metrics["policy"] if name.startswith("expert-")})
    if len(experts) != 1:
        raise SystemExit(f"expected one expert among the drivers, found {experts or 'none'}")
    return experts[0]


def evaluation_files(out: Path, pattern: str = "test_s*.parquet") -> list[Path]:
    """The metrics files of `out` that match `pattern`, without the per-decision records and summaries beside them."""
    return sorted(path for path in out.glob(pattern) if not path.name.endswith(DERIVED))


def read_evaluations(out: Path) -> tuple[pd.DataFrame, pd.DataFrame | None, int, str]:
    """All test_sSEED evaluations as one metrics table (the expert once), their per-decision records (None when
    some file's are not there: not committed, SUMMARY holds what the table reads of them), the scenario's lane count
    and the expert's name (`expert_driver`)."""
    paths = evaluation_files(out)
    if not paths:
        raise SystemExit(f"no evaluation test_sSEED.parquet in {out} yet")
    metrics = [pd.read_parquet(path) for path in paths]
    decisions = ([pd.read_parquet(decisions_path(path)) for path in paths]
                 if all(decisions_path(path).is_file() for path in paths) else None)
    expert = expert_driver(metrics[0])
    expert_seeds = sorted(metrics[0].loc[metrics[0]["policy"] == expert, "seed"])
    for path, frame in zip(paths, metrics, strict=True):
        for driver, episodes in frame.groupby("policy"):
            if sorted(episodes["seed"]) != expert_seeds:
                raise SystemExit(f"{path}: {driver} was not evaluated on the same episodes as {paths[0]}'s expert")
    lanes = int(read_metadata(paths[0])["config"]["scenario"]["lanes"])
    keep_expert = [True] + [False] * (len(paths) - 1)
    return (pd.concat([frame[(frame["policy"] != expert) | keep] for frame, keep in zip(metrics, keep_expert,
                                                                                          strict=True)]),
            None if decisions is None else pd.concat([frame[(frame["policy"] != expert) | keep] for frame, keep
                                                      in zip(decisions, keep_expert, strict=True)]),
            lanes, expert)


def decisions_summary(out: Path, decisions: pd.DataFrame | None, expert: str, lanes: int) -> pd.DataFrame:
    """What the table reads of the pooled per-decision records (`decision_summary`): made from them, or OUT/SUMMARY
    where they are not there (`--summary` writes it from them)."""
    if decisions is not None:
        return decision_summary(decisions, expert, lanes)
    if not (out / SUMMARY).is_file():
        raise SystemExit(f"neither the per-decision records of {out}'s evaluations nor {out / SUMMARY}: the "
                         f"evaluations' grid spec writes the records again")
    return pd.read_parquet(out / SUMMARY)


def budget(out: Path, stem: str, seeds: list[int]) -> str:
    """Mean environment decisions and wall time [min] of a method's training runs (BC: none beyond the demos)."""
    logs = [out / f"{stem}_s{seed}" / "log.parquet" for seed in seeds]
    if not all(log.is_file() for log in logs):
        return "0 | 0"
    frames = [pd.read_parquet(log, columns=["env_steps", "wall_time_s"]) for log in logs]
    steps = sum(frame["env_steps"].sum() for frame in frames) / len(frames)
    minutes = sum(frame["wall_time_s"].sum() for frame in frames) / len(frames) / 60
    return f"{steps:,.0f} | {minutes:.1f}"


Found = dict[str, tuple[list[int], list[dict[str, Sample]]]]
"""method key -> (its training seeds, each seed's measure samples)."""


def methods_found(metrics: pd.DataFrame, methods: dict[str, tuple[str, str, str]] = METHODS) -> Found:
    """The `methods` (key: (label, run folder stem, policy)) found in the evaluations."""
    found = {}
    for key, (_, stem, policy) in methods.items():
        seeds = training_seeds(metrics, stem)
        if seeds:
            found[key] = (seeds, seed_samples(metrics, stem, seeds, policy))
    return found


def print_headline(expert: dict[str, Sample], found: Found, headline: tuple[str, ...] = HEADLINE,
                   methods: dict[str, tuple[str, str, str]] = METHODS) -> None:
    """One row a method: each headline measure pooled over its seeds, with its 95% interval."""
    print("| method | training seeds | " + " | ".join(headline) + " |")
    print("|---|---|" + "---|" * len(headline))
    print("| expert | - | " + " | ".join(interval(expert[measure]).format(digits_of(measure))
                                        for measure in headline) + " |")
    for key, (seeds, samples) in found.items():
        cells = [pooled(samples, measure).format(digits_of(measure)) for measure in headline]
        print(f"| {methods[key][0]} | {len(seeds)} | " + " | ".join(cells) + " |")


def print_comparisons(found: Found, comparisons: tuple[tuple[str, str], ...], measures: tuple[str, ...],
                      methods: dict[str, tuple[str, str, str]] = METHODS) -> None:
    """Each (candidate, reference) method pair's paired differences, on the training seeds both have."""
    print("\n| comparison | measure | paired difference |")
    print("|---|---|---|")
    for candidate, reference in comparisons:
        if candidate not in found or reference not in found:
            continue
        seeds = sorted(set(found[candidate][0]) & set(found[reference][0]))  # paired on the seeds both have
        pair = [[samples for seed, samples in zip(*found[key], strict=True) if seed in seeds]
                for key in (candidate, reference)]
        for measure in measures:
            cell = difference_cell(*pair, measure, digits_of(measure))
            print(f"| {methods[candidate][0]} - {methods[reference][0]} ({seeds}) | {measure} | {cell} |")


def main(out: Path, write_summary: bool = False) -> None:
    metrics, decisions, lanes, expert_name = read_evaluations(out)
    summary = decisions_summary(out, decisions, expert_name, lanes)
    if write_summary:
        if decisions is None:
            raise SystemExit(f"--summary: no per-decision records in {out} to summarise")
        summary.to_parquet(out / SUMMARY)
    expert = measure_samples(metrics[metrics["policy"] == expert_name].sort_values("seed"))
    found = methods_found(metrics)
    episodes = int((metrics["policy"] == expert_name).sum())
    print(f"{episodes} test episodes; cells: value [95% interval] over training runs and episodes "
          f"(experiments/seeded.py), each run's own estimate in brackets; differences paired by run and episode.\n")
    print_headline(expert, found)
    print()
    print("| method (seeds) | measure | value | minus the expert |")
    print("|---|---|---|---|")
    for measure in MEASURES:
        print(f"| expert | {measure} | {interval(expert[measure]).format(digits_of(measure))} | - |")
    for key, (seeds, samples) in found.items():
        for measure in MEASURES:
            digits = digits_of(measure)
            print(f"| {METHODS[key][0]} ({seeds}) | {measure} | {value_cell(samples, measure, digits)} | "
                  f"{difference_cell(samples, [expert] * len(samples), measure, digits)} |")
    print_comparisons(found, COMPARISONS, MEASURES)
    print("\n| method | environment decisions in training (mean over seeds) | training wall time [min] (RAIL's "
          "includes its validation every 10 iterations) |")
    print("|---|---:|---:|")
    for key, (seeds, _) in found.items():
        print(f"| {METHODS[key][0]} | {budget(out, METHODS[key][1], seeds)} |")
    print("\n```\n" + distance_text(summary_distances(summary, expert_name), expert_name) + "\n```")


@click.command(help=__doc__)
@click.argument("out", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--summary", is_flag=True, help="Also write the decisions' summary beside the evaluations.")
def cli(out: Path, summary: bool) -> None:
    main(out, summary)


if __name__ == "__main__":
    cli()
