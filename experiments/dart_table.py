"""The DART rows of the benchmark and the benchmark's safety measures (issue 36), as Markdown: DART (BC on the
demonstrations of specs/dart.toml) and RAIL started from it (specs/dart.toml's rail steps, DART_DIR/rail) against the
committed BC, RAIL, DAgger and GAIL runs on the same test episodes, paired by training seed and episode as
experiments/benchmark_table.py pairs them; then the safety measures of every method (from the SAFETY_DIRs,
specs/safety_table.toml, and DART's own evaluations), and a check that the re-evaluation reproduces every
committed column. DART_DIR "-": no DART (the realizable benchmark's safety table).

Usage: python experiments/dart_table.py BENCH_DIR DART_DIR|- [SAFETY_DIR ...]   (each holds test_sSEED.parquet files)
"""

from __future__ import annotations

from pathlib import Path

import click
import pandas as pd
from benchmark_table import (
    DERIVED,
    HEADLINE,
    METHODS,
    Found,
    expert_driver,
    methods_found,
    print_comparisons,
    print_headline,
)
from seeded import difference_cell, digits_of

from sumo_rail.evaluation.safety import SAFETY_MEASURES
from sumo_rail.evaluation.summary import measure_samples

DART_METHODS = {**{key: METHODS[key] for key in ("bc_mlp", "rail_mlp", "dagger", "gail", "gail_sampled")},
                "dart": ("DART, two-layer", "dart", "policy_bc"),
                "rail_dart": ("RAIL from DART, two-layer", "rail_dart", "policy_latest")}
COMPARISONS = (("dart", "bc_mlp"), ("dart", "dagger"), ("dart", "rail_mlp"), ("dagger", "bc_mlp"),
               ("rail_dart", "dart"), ("rail_dart", "rail_mlp"), ("rail_mlp", "gail"))
SAFETY = (*SAFETY_MEASURES, "hard_braking", "collisions")


def evaluations(*folders: Path) -> pd.DataFrame:
    """Every test_sSEED*.parquet metrics file of `folders`, one row per (driver, episode seed)."""
    paths = [path for folder in folders for path in sorted(folder.glob("test_s*.parquet"))
             if not path.name.endswith(DERIVED)]
    if not paths:
        raise SystemExit(f"no test_sSEED.parquet in {', '.join(map(str, folders))}")
    return pd.concat([pd.read_parquet(path) for path in paths]).drop_duplicates(["policy", "seed"])


def method_table(metrics: pd.DataFrame, measures: tuple[str, ...]) -> None:
    """The methods' pooled values, each method minus the expert and the paired comparisons, for `measures`."""
    expert_name = expert_driver(metrics)
    expert = measure_samples(metrics[metrics["policy"] == expert_name].sort_values("seed"))
    episodes = sorted(metrics.loc[metrics["policy"] == expert_name, "seed"])
    for driver, frame in metrics.groupby("policy"):
        if sorted(frame["seed"]) != episodes:
            raise SystemExit(f"{driver} was not evaluated on the expert's episodes")
    found = methods_found(metrics, DART_METHODS)
    print_headline(expert, found, measures, DART_METHODS)
    print("\n| method (seeds) | measure | minus the expert |")
    print("|---|---|---|")
    for key, (seeds, samples) in found.items():
        for measure in measures:
            cell = difference_cell(samples, [expert] * len(samples), measure, digits_of(measure))
            print(f"| {DART_METHODS[key][0]} ({seeds}) | {measure} | {cell} |")
    print_comparisons(found, COMPARISONS, measures, DART_METHODS)
    if "agreement" in measures and {"dart", "bc_mlp", "dagger"} <= found.keys():
        seeds = sorted(set(found["dart"][0]) & set(found["bc_mlp"][0]) & set(found["dagger"][0]))
        pooled = {key: pooled_agreement(found, key, seeds) for key in ("dart", "bc_mlp", "dagger")}
        gap = (pooled["dart"] - pooled["bc_mlp"]) / (pooled["dagger"] - pooled["bc_mlp"])
        print(f"\nShare of the BC-to-DAgger agreement gap DART closes on seeds {seeds} (point estimate): {gap:.2f}")


def pooled_agreement(found: Found, key: str, seeds: list[int]) -> float:
    """A method's agreement pooled over the decisions of its runs with training seeds `seeds`."""
    runs = [samples["agreement"] for seed, samples in zip(*found[key], strict=True) if seed in seeds]
    return float(sum(run[0].sum() for run in runs) / sum(run[1].sum() for run in runs))


def reproduces(committed: pd.DataFrame, again: pd.DataFrame) -> str:
    """Whether every column the committed evaluation has is the same in the re-evaluation, for the drivers both
    hold."""
    keys = ["policy", "seed"]
    both = committed.merge(again, on=keys, suffixes=("", "_again"))
    columns = [name for name in committed.columns if name not in keys and f"{name}_again" in both]
    differing = [name for name in columns if not both[name].equals(both[f"{name}_again"])]
    return (f"{len(both)} episodes of {both['policy'].nunique()} drivers, {len(columns)} columns: "
            + ("every value the same" if not differing else f"differing in {', '.join(differing)}"))


def main(bench: Path, dart: Path | None, safety: list[Path]) -> None:
    committed = evaluations(bench)
    darts = evaluations(*[folder for folder in (dart, dart / "rail") if folder.is_dir()]) if dart else committed[:0]
    print("## The benchmark with DART (test episodes; cells: value [95% interval] over training runs and episodes)\n")
    method_table(pd.concat([committed, darts]).drop_duplicates(["policy", "seed"]), HEADLINE)
    if safety:
        again = evaluations(*safety)
        print("\n## Safety measures (test episodes)\n")
        same_episodes = darts[darts["seed"].isin(set(again["seed"]))]  # the re-evaluation may hold fewer episodes
        method_table(pd.concat([again, same_episodes]).drop_duplicates(["policy", "seed"]), SAFETY)
        print(f"\nThe re-evaluation against the committed evaluation: {reproduces(committed, again)}.")


@click.command(help=__doc__)
@click.argument("bench", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.argument("dart", metavar="DART_DIR|-")
@click.argument("safety", nargs=-1, type=click.Path(exists=True, file_okay=False, path_type=Path))
def cli(bench: Path, dart: str, safety: tuple[Path, ...]) -> None:
    if dart != "-" and not Path(dart).is_dir():
        raise click.BadParameter(f"{dart} is not a folder (give - for none)", param_hint="DART_DIR")
    main(bench, None if dart == "-" else Path(dart), list(safety))


if __name__ == "__main__":
    cli()
