"""`sumo-rail report`: the figures of sumo_rail.report.plots as PNG files and a Markdown summary, in one folder.

Every file is written atomically (a temporary file in the same folder, then a rename), so an interrupted report
never leaves a half-written file; report.md is written last.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from matplotlib.figure import Figure

from sumo_rail.evaluation.evaluate import summary_table
from sumo_rail.report.inputs import Inputs, ReportError, Run
from sumo_rail.report.plots import DPI, learning_curves, metric_bars, validation_curves, weight_maps

REPORT_FILE = "report.md"


@dataclass(frozen=True)
class Plot:
    """One PNG of the report."""

    file: str
    title: str
    caption: str


def write_report(inputs: Inputs, out: Path) -> Path:
    """Write every plot the inputs allow and report.md into `out` (created); returns the path of report.md."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ReportError(f"cannot create the output folder {out}: {error.strerror or error}") from error
    plots: list[Plot] = []

    def add(plot: Plot, draw: Callable[[], Figure]) -> None:
        save_png(draw(), out / plot.file)
        plots.append(plot)

    runs = inputs.runs
    if runs:
        add(Plot("learning_curves.png", "Learning curves",
                 "Mean discriminator return of each iteration's rollouts (RAIL: the perturbed rollouts; GAIL: "
                 "the episodes of a PPO update) (band: +- std, dashed: best rollout) against cumulative "
                 "environment steps."), lambda: learning_curves(runs))
    if any(not run.evaluated.empty for run in runs):
        add(Plot("validation.png", "Validation",
                 "Speed, overtakes, lane changes and collisions of the policy on validation seeds during training."),
            lambda: validation_curves(runs))
    if inputs.metrics is not None:
        metrics = inputs.metrics
        add(Plot("metrics.png", "Evaluation metrics",
                 "The evaluation table as bar charts: mean +- std over episodes for each driver."),
            lambda: metric_bars(metrics))
    for run in runs:
        if run.policies:
            add(Plot(f"weights_{run.name}.png", f"Policy weights of {run.name}",
                     f"Weights of {' and '.join(run.policies)} per layer as heat maps (one colour scale per layer) "
                     f"and histograms."), lambda run=run: weight_maps(run))
    path = out / REPORT_FILE
    write_atomically(path, markdown(inputs, plots).encode())
    return path


def markdown(inputs: Inputs, plots: list[Plot]) -> str:
    """The report text: runs table, evaluation summary, and every plot with its caption."""
    lines = ["# sumo-rail report", ""]
    if inputs.runs:
        lines += ["## Training runs", "", *run_table(inputs.runs), "",
                  "D return: mean over one iteration's rollouts (RAIL: perturbed rollouts; GAIL: a PPO update's "
                  "episodes) of the per-decision discriminator reward "
                  "log D - log(1 - D); iterations count from 1; wall time sums the iterations (without behaviour "
                  "cloning); validation: means over the validation episodes of the last evaluated iteration.", ""]
    if inputs.metrics is not None:
        files = ", ".join(f"`{path}`" for path in inputs.metrics_files)
        lines += ["## Evaluation", "", f"From {files}:", "", "```text", summary_table(inputs.metrics), "```", ""]
    if plots:
        lines += ["## Plots", ""]
        for plot in plots:
            lines += [f"### {plot.title}", "", f"![{plot.title}]({plot.file})", "", f"*{plot.caption}*", ""]
    return "\n".join(lines)


def run_table(runs: list[Run]) -> list[str]:
    """One Markdown table row per run."""
    header = ("| run | policy | iterations | env steps | wall time (min) | final D return | best D return (iteration) "
              "| validated at iteration | speed (km/h) | overtakes | lane changes | collisions |")
    rows = [header, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for run in runs:
        log = run.log
        best = int(log["return_mean"].idxmax())
        cells = [run.name, run.kind, f"{len(log)}", f"{int(log['env_steps'].sum()):,}",
                 f"{log['wall_time_s'].sum() / 60:.1f}", f"{log['return_mean'].iloc[-1]:+.3f}",
                 f"{log['return_mean'].iloc[best]:+.3f} ({int(log['iteration'].iloc[best]) + 1})",
                 *_last_validation(run)]
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def _last_validation(run: Run) -> list[str]:
    evaluated = run.evaluated
    if evaluated.empty:
        return ["-"] * 5
    last = evaluated.iloc[-1]
    return [f"{int(last['iteration']) + 1}", f"{last['eval_average_speed_kmh']:.1f}", f"{last['eval_overtakes']:.2f}",
            f"{last['eval_lane_changes']:.2f}", f"{last['eval_collisions']:.2f}"]


def save_png(figure: Figure, path: Path) -> None:
    """Render `figure` to a PNG at `path` atomically."""
    temporary = _temporary(path)
    try:
        figure.savefig(temporary, format="png", dpi=DPI)
        os.replace(temporary, path)
    except OSError as error:
        raise ReportError(f"cannot write {path}: {error.strerror or error}") from error
    finally:
        temporary.unlink(missing_ok=True)


def write_atomically(path: Path, content: bytes) -> None:
    temporary = _temporary(path)
    try:
        temporary.write_bytes(content)
        os.replace(temporary, path)
    except OSError as error:
        raise ReportError(f"cannot write {path}: {error.strerror or error}") from error
    finally:
        temporary.unlink(missing_ok=True)


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")

