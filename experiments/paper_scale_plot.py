"""The figure of specs/paper_scale.toml: RAIL from BC at the paper's N = 512 beside the benchmark's N = 32 run of
the same seed: validation agreement with the expert against decisions, and the discriminator's mean return against
iterations. Prints a table of each run's cost and validations. Writes OUT.png.

Usage: python experiments/paper_scale_plot.py OUT.png RUN_DIR [RUN_DIR ...]   (each RUN_DIR holds a train run's
run.json and log.parquet)
"""

from __future__ import annotations

import json
from pathlib import Path

import click
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def label(run: Path) -> str:
    """'N = 512, alpha 0.02, K = 8 respawning (seed 0)' from the run's settings."""
    rail = json.loads((run / "run.json").read_text())["settings"]["rail"]
    egos = rail.get("egos", 1)
    rollouts = (f", K = {egos} respawning" if rail.get("rollout_decisions") else f", K = {egos}" if egos > 1
                else "")
    return f"N = {rail['directions']}, alpha {rail['step_size']:g}{rollouts} (seed {rail['seed']})"


def main(out: str, *runs: str) -> None:
    figure = Figure(figsize=(11, 4))
    FigureCanvasAgg(figure)
    agreement, returns = figure.subplots(1, 2)
    print("| run | iterations | decisions per iteration | wall time per iteration [s] | validation agreement "
          "(iteration: value) |")
    print("|---|---:|---:|---:|---|")
    for run in map(Path, runs):
        log = pd.read_parquet(run / "log.parquet")
        log["decisions"] = log["env_steps"].cumsum()
        validated = log.dropna(subset=["eval_agreement"])
        name = label(run)
        agreement.plot(validated["decisions"], validated["eval_agreement"], marker="o", label=name)
        returns.plot(log["iteration"], log["return_mean"], label=name)
        values = ", ".join(f"{int(row.iteration)}: {row.eval_agreement:.3f}" for row in validated.itertuples())
        print(f"| {name} | {len(log)} | {log['env_steps'].mean():,.0f} | {log['wall_time_s'].median():.0f} | "
              f"{values} |")
    agreement.set(xlabel="decisions", ylabel="validation agreement with the expert", xscale="log")
    returns.set(xlabel="iteration", ylabel="mean discriminator return of the rollouts")
    agreement.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out, dpi=120)


@click.command(help=__doc__)
@click.argument("out", type=click.Path(dir_okay=False))
@click.argument("runs", nargs=-1, required=True, type=click.Path(exists=True, file_okay=False))
def cli(out: str, runs: tuple[str, ...]) -> None:
    main(out, *runs)


if __name__ == "__main__":
    cli()
