"""`sumo-rail report`: the figures of sumo_rail.report.plots as PNG files and a Markdown summary, in one folder.

Every file is written atomically (a temporary file in the same folder, then a rename), so an interrupted report
never leaves a half-written file; report.md is written last.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

from sumo_rail.datasets import file_in_the_way, write_bytes_atomically, write_failures, written_atomically
from sumo_rail.evaluation.distributions import decision_summary, summary_distances
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS
from sumo_rail.evaluation.summary import intervals, paired_differences, summary_table
from sumo_rail.report.fidelity_plots import agreement_bars, behaviour_distributions, confusion_maps, forest_plot
from sumo_rail.report.inputs import Inputs, ReportError, Run
from sumo_rail.report.plots import DPI, learning_curves, metric_bars, validation_curves, weight_maps

REPORT_FILE = "report.md"


@dataclass(frozen=True)
class Plot:
    """One PNG of the report."""

    file: str
    title: str
    caption: str


def write_report(inputs: Inputs, out: Path, videos: Path | None = None) -> Path:
    """Write every plot the inputs allow and report.md into `out` (created); returns the path of report.md. With
    `videos` (a folder written by evaluate --video), also GIFs of each driver above the expert on the same seed."""
    blocking = file_in_the_way(out)
    if blocking is not None:
        raise ReportError(f"cannot create the output folder {out}: {blocking} is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ReportError(f"cannot create the output folder {out}: {error.strerror or error}") from error
    plots: list[Plot] = []

    def add(plot: Plot, draw: Callable[[], Figure]) -> None:
        save_png(draw(), out / plot.file)
        plots.append(plot)

    runs = inputs.runs
    if runs and runs[0].method == "PPO":
        add(Plot("learning_curves.png", "Learning curves",
                 "Mean environment return (the env's reward plus any shaping, what PPO maximises) of the episodes "
                 "that ended in each update (band: +- std, dashed: best episode) against cumulative environment "
                 "steps."), lambda: learning_curves(runs))
    elif any(run.log["return_mean"].notna().any() for run in runs):  # a DAgger run has no return
        add(Plot("learning_curves.png", "Learning curves",
                 "Mean discriminator return of each iteration's rollouts (RAIL: the perturbed rollouts; GAIL: "
                 "the episodes of a PPO update) (band: +- std, dashed: best rollout) against cumulative "
                 "environment steps."), lambda: learning_curves(runs))
    if any(not run.evaluated.empty for run in runs):
        add(Plot("validation.png", "Validation",
                 "Speed, overtakes, lane changes and collisions of the policy on validation seeds during training."),
            lambda: validation_curves(runs))
    if inputs.metrics is not None:
        _evaluation_plots(inputs, inputs.metrics, add)
    for run in runs:
        if run.policies:
            add(Plot(f"weights_{run.name}.png", f"Policy weights of {run.name}",
                     f"Weights of {' and '.join(run.policies)} per layer as heat maps (one colour scale per layer) "
                     f"and histograms."), partial(weight_maps, run))
    if videos is not None:
        from sumo_rail.report.videos import GIF_FRAMES, GIF_SPEED_UP, comparison_gifs

        for gif in comparison_gifs(videos, out):
            plots.append(Plot(gif.file, f"{gif.driver} and {gif.expert} on the same seed",
                              f"Evaluation episode {gif.episode} (seed {gif.seed}): {gif.driver} (top) and "
                              f"{gif.expert} (bottom) from the same traffic, the first {GIF_FRAMES} decisions at "
                              f"{GIF_SPEED_UP:g}x real time; bird's-eye view with the LIDAR beams (red: the ego)."))
    path = out / REPORT_FILE
    write_atomically(path, markdown(inputs, plots).encode())
    return path


def _evaluation_plots(inputs: Inputs, metrics: pd.DataFrame, add: Callable[[Plot, Callable[[], Figure]], None]) -> None:
    estimates = intervals(metrics, route=inputs.route)
    drivers = list(dict.fromkeys(metrics["policy"]))
    add(Plot("metrics.png", "Evaluation metrics",
             "The evaluation table as bar charts: mean over episodes for each driver with its 95% interval "
             "(bootstrap over episodes)."), lambda: metric_bars(metrics, estimates))
    if set(CONFUSION_COLUMNS) <= set(metrics.columns):
        add(Plot("agreement.png", "Agreement with the expert",
                 "At every decision of each driver, the reference expert was asked what it would do in that very "
                 "traffic: the share of decisions where they agree, overall, lateral (keep lane / left / right) and "
                 "longitudinal (set-point up / down / hold), and lane-change recall and precision, pooled over "
                 "decisions with 95% intervals (bootstrap over episodes)."), lambda: agreement_bars(estimates))
        add(Plot("confusion.png", "Confusion matrices",
                 "Decisions by driver action (rows) and expert action (columns); colour: share of the expert's "
                 "column, so the diagonal is the expert's recall per action."), lambda: confusion_maps(metrics))
    expert = reference_expert(metrics)
    summary = decisions_summary(inputs, expert)
    if summary is not None and len(drivers) > 1:
        add(Plot("distributions.png", "Behaviour distributions",
                 f"Speed, time headway and lane occupancy at every decision, each driver over {expert}'s."),
            lambda: behaviour_distributions(summary, expert))
    if len(drivers) > 1:
        differences = paired_differences(metrics, drivers[0])
        add(Plot("differences.png", "Paired differences",
                 f"Each driver minus {drivers[0]} on the same seeds, with 95% intervals (bootstrap over seeds); "
                 "filled markers: the interval excludes 0, a detectable difference."),
            lambda: forest_plot(differences, drivers[0]))


def reference_expert(metrics: pd.DataFrame) -> str:
    """The driver name of the reference expert the metrics were compared with (expert-normal by default; files
    written before any driver could be the expert hold its style in `reference_style`)."""
    if "reference" in metrics and len(metrics["reference"].dropna()):
        return str(metrics["reference"].dropna().iloc[0])
    if "reference_style" in metrics and len(styles := metrics["reference_style"].dropna()):
        return f"expert-{styles.iloc[0]}"
    return "expert-normal"


def decisions_summary(inputs: Inputs, expert: str) -> pd.DataFrame | None:
    """What the report reads of the per-decision records (`decision_summary`): made from the records, or the summary
    committed in their place beside a metrics file; None without either or without `expert` among the drivers."""
    if inputs.decisions is not None:
        if expert not in set(inputs.decisions["policy"]):
            return None
        return decision_summary(inputs.decisions, expert, int(max(inputs.decisions["lane"].max() + 1, 1)))
    return inputs.summary if inputs.summary is not None and expert in inputs.summary.index else None


def markdown(inputs: Inputs, plots: list[Plot]) -> str:
    """The report text: runs table, evaluation summary, and every plot with its caption."""
    lines = ["# sumo-rail report", ""]
    if inputs.runs:
        environment = inputs.runs[0].method == "PPO"
        lines += ["## Training runs", "", *run_table(inputs.runs), "",
                  "env return: mean over the episodes that ended in one PPO update of the environment's return (its "
                  "reward plus any shaping); updates count from 1; wall time sums the updates." if environment else
                  "D return: mean over one iteration's rollouts (RAIL: perturbed rollouts; GAIL: a PPO update's "
                  "episodes) of the per-decision discriminator reward "
                  "log D - log(1 - D) (DAgger: none); iterations and updates count from 1, DAgger's rounds from 0 "
                  "(its first BC); wall time sums them (without behaviour cloning); validation: means over the "
                  "validation episodes of the last evaluated one.", ""]
    if inputs.metrics is not None:
        files = ", ".join(f"`{path}`" for path in inputs.metrics_files)
        lines += ["## Evaluation", "", f"From {files}:", "", "```text",
                  summary_table(inputs.metrics, route=inputs.route), "```", ""]
        if not set(CONFUSION_COLUMNS) <= set(inputs.metrics.columns):
            lines += ["These metrics files predate the comparison with the expert (no confusion counts): agreement, "
                      "lane-change precision and recall are absent.", ""]
        expert = reference_expert(inputs.metrics)
        summary = decisions_summary(inputs, expert)
        if summary is not None:
            table = summary_distances(summary, expert)
            lines += [f"Distances of each driver's distributions to {expert}'s (Wasserstein-1 in the unit named; "
                      "total variation for lanes and actions; no-leader share: difference):", "",
                      "```text", table.round(3).to_string(), "```", ""]
    if plots:
        lines += ["## Plots", ""]
        for plot in plots:
            lines += [f"### {plot.title}", "", f"![{plot.title}]({plot.file})", "", f"*{plot.caption}*", ""]
    return "\n".join(lines)


def run_table(runs: list[Run]) -> list[str]:
    """One Markdown table row per run."""
    name = runs[0].return_name if runs else "D return"  # runs of one table share their method's kind of return
    names = list(dict.fromkeys(run.step_name for run in runs)) or ["iteration"]
    step, steps = "/".join(names), "/".join(f"{one}s" for one in names)
    header = (f"| run | road | policy | {steps} | env steps | wall time (min) | final {name} | best {name} ({step}) "
              f"| validated at {step} | speed (km/h) | overtakes | lane changes | collisions |")
    rows = [header, "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for run in runs:
        log, returns = run.log, run.log["return_mean"].dropna()  # a ppo update in which no episode ended has none
        best = "-" if returns.empty else (f"{returns.max():+.3f} "
                                          f"({int(log['iteration'].loc[returns.idxmax()]) + _first(run)})")
        final = "-" if pd.isna(log["return_mean"].iloc[-1]) else f"{log['return_mean'].iloc[-1]:+.3f}"
        cells = [run.name, run.road, run.kind, f"{len(log)}", f"{int(log['env_steps'].sum()):,}",
                 f"{log['wall_time_s'].sum() / 60:.1f}", final, best, *_last_validation(run)]
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def _last_validation(run: Run) -> list[str]:
    evaluated = run.evaluated
    if evaluated.empty:
        return ["-"] * 5
    last = evaluated.iloc[-1]
    return [f"{int(last['iteration']) + _first(run)}", f"{last['eval_average_speed_kmh']:.1f}",
            f"{last['eval_overtakes']:.2f}", f"{last['eval_lane_changes']:.2f}", f"{last['eval_collisions']:.2f}"]


def _first(run: Run) -> int:
    """The number of a run's first log row: DAgger's rounds count from 0 (BC), iterations and updates from 1."""
    return 0 if run.method == "DAgger" else 1


def save_png(figure: Figure, path: Path) -> None:
    """Render `figure` to a PNG at `path` atomically."""
    with write_failures(path, ReportError), written_atomically(path) as temporary:
        figure.savefig(temporary, format="png", dpi=DPI)


def write_atomically(path: Path, content: bytes) -> None:
    with write_failures(path, ReportError):
        write_bytes_atomically(path, content)

