"""The report's figures, one function each; matplotlib's object API on the Agg canvas (no pyplot, no display)."""

from __future__ import annotations

from typing import Literal

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import EngFormatter

from sumo_rail.drivers.policies import Policy, PolicyShape, _unflatten
from sumo_rail.report.inputs import ACTION_NAMES, Run

DPI = 120
STEPS_LABEL = "environment steps (decisions)"
STEPS_FORMAT = EngFormatter(sep="")
"""Step counts as 50k, 1.2M: long plain numbers overlap on a shared axis."""
VALIDATION_PANELS = (("eval_agreement", "agreement with the expert (share of decisions)"),
                     ("eval_lane_change_recall", "lane-change recall (share of the expert's)"),
                     ("eval_average_speed_kmh", "average speed (km/h)"),
                     ("eval_overtakes", "overtakes per episode"),
                     ("eval_lane_changes", "lane changes per episode"),
                     ("eval_collisions", "collisions per episode"))
METRIC_PANELS = (("average_speed_kmh", "average speed (km/h)"),
                 ("overtakes", "overtakes per episode"),
                 ("lane_changes", "lane changes per episode"),
                 ("longitudinal_reward", "longitudinal reward (sum per episode)"),
                 ("lateral_reward", "lateral reward (sum per episode)"),
                 ("collisions", "collisions per episode"))
POLICY_COLOURS = {"BC": "tab:orange", "RAIL": "tab:blue", "GAIL": "tab:green", "PPO": "tab:purple",
                  "DAgger": "tab:red"}
WEIGHT_COLOURMAP = "RdBu_r"


def learning_curves(runs: list[Run]) -> Figure:
    """Mean return of each iteration's rollouts (band: +- std; dashed: max) vs cumulative env steps: the
    discriminator's, or the environment's for `ppo` runs (`read_inputs` does not mix them)."""
    figure = _figure(9.5, 5.5)
    axes = figure.add_subplot()
    handles = []
    for index, run in enumerate(runs):
        log, colour = run.log, _colour(index)
        steps = log["cumulative_env_steps"]
        handles += axes.plot(steps, log["return_mean"], color=colour, marker=_marker(log), markersize=4,
                             label=run.name)
        axes.fill_between(steps, log["return_mean"] - log["return_std"], log["return_mean"] + log["return_std"],
                          color=colour, alpha=0.18, linewidth=0)
        axes.plot(steps, log["return_max"], color=colour, linestyle="--", linewidth=1)
    style = [Line2D([], [], color="grey", label="mean over rollouts"),
             Patch(color="grey", alpha=0.3, label="mean +- std"),
             Line2D([], [], color="grey", linestyle="--", label="best rollout")]
    axes.legend(handles=[*handles, *style], fontsize=9, loc="best")
    if runs and runs[0].method == "PPO":
        axes.set(ylabel="environment return\n(reward plus shaping per episode)",
                 title="Learning curves: environment return of each update's episodes")
    else:
        axes.set(ylabel="discriminator return\n(mean log D - log(1 - D) per decision)",
                 title="Learning curves: discriminator return of each iteration's rollouts")
    axes.set(xlabel=STEPS_LABEL)
    axes.xaxis.set_major_formatter(STEPS_FORMAT)
    _grid(axes)
    return figure


def validation_curves(runs: list[Run]) -> Figure:
    """Validation metrics (mean over validation episodes) vs cumulative env steps, one panel per metric; agreement
    with its 95% interval as a band where the log holds it."""
    figure = _figure(15, 7.5)
    panels = figure.subplots(2, 3, sharex=True).ravel()
    for axes, (column, label) in zip(panels, VALIDATION_PANELS, strict=True):
        for index, run in enumerate(runs):
            rows = run.evaluated
            if not rows.empty:
                axes.plot(rows["cumulative_env_steps"], rows[column], color=_colour(index), marker="o",
                          markersize=4, label=run.name)
                if column == "eval_agreement" and {f"{column}_low", f"{column}_high"} <= set(rows.columns):
                    axes.fill_between(rows["cumulative_env_steps"], rows[f"{column}_low"], rows[f"{column}_high"],
                                      color=_colour(index), alpha=0.15, linewidth=0)
        if all(run.evaluated[column].isna().all() for run in runs):
            axes.text(0.5, 0.5, "not in these logs (runs from before it was measured)", ha="center",
                      va="center", transform=axes.transAxes, color="grey")
        axes.set(ylabel=label, title=label.split(" (")[0].replace(" per episode", ""))
        _grid(axes)
    for axes in panels[3:]:
        axes.set_xlabel(STEPS_LABEL)
        axes.xaxis.set_major_formatter(STEPS_FORMAT)
    panels[0].legend(fontsize=9)
    figure.suptitle("Validation during training: the policy on held-out validation seeds (mean over episodes)")
    return figure


def metric_bars(metrics: pd.DataFrame, intervals: pd.DataFrame) -> Figure:
    """The paper's table as bar charts: mean over episodes per driver with its 95% interval (`intervals`: rows of
    `evaluation.summary.intervals`), drivers in order of appearance."""
    drivers = list(dict.fromkeys(metrics["policy"]))
    episodes = metrics.groupby("policy", sort=False).size()
    figure = _figure(min(20.0, 12.0 + 0.6 * max(0, len(drivers) - 4)), 7.5)
    positions = np.arange(len(drivers))
    long_names = max(len(driver) for driver in drivers) * len(drivers) > 40
    for axes, (column, label) in zip(figure.subplots(2, 3).ravel(), METRIC_PANELS, strict=True):
        rows = intervals[intervals["measure"] == column].set_index("policy").loc[drivers]
        errors = np.vstack([rows["estimate"] - rows["low"], rows["high"] - rows["estimate"]])
        axes.bar(positions, rows["estimate"], yerr=errors, capsize=4, color=[_colour(i) for i in range(len(drivers))],
                 error_kw={"elinewidth": 1})
        axes.set_xticks(positions, drivers, rotation=30 if long_names else 0, ha="right" if long_names else "center",
                        fontsize=9)
        axes.set(ylabel=label, title=label.split(" (")[0].replace(" per episode", ""))
        axes.axhline(0, color="black", linewidth=0.6)
        if not metrics[column].any():
            axes.set_ylim(0, 1)  # all zero (e.g. no collisions): a plain axis rather than +-0.05
        _grid(axes, axis="y")
    counts = (f"{episodes.iloc[0]} each" if episodes.nunique() == 1
              else ", ".join(f"{driver}: {episodes[driver]}" for driver in drivers))
    figure.suptitle(f"Evaluation metrics per driver: mean over episodes with its 95% interval ({counts})")
    return figure


def weight_maps(run: Run) -> Figure:
    """Heat maps of each layer's weights for BC and the trained policy (shared colour scale per layer) and their
    histograms."""
    labels = list(run.policies)
    weights = {label: weight_matrices(policy) for label, (policy, _) in run.policies.items()}
    shape = run.policies[labels[0]][0].shape
    layers = len(weights[labels[0]])
    figure = _figure(15, 2.4 * len(labels) + 5.2)
    outer = figure.add_gridspec(2, 1, height_ratios=[2.4 * len(labels) + 1.6, 2.8])
    ratios = [4.0, 1.3][:layers]
    heat = outer[0].subgridspec(len(labels), layers, width_ratios=ratios)
    histograms = outer[1].subgridspec(1, layers)
    for layer in range(layers):
        matrices = [weights[label][layer] for label in labels]
        limit = max(float(np.abs(matrix).max()) for matrix in matrices) or 1.0
        inputs, outputs = _layer_axes(shape, run.observation_names, layer)
        column_axes: list[Axes] = []
        for row, (label, matrix) in enumerate(zip(labels, matrices, strict=True)):
            axes = figure.add_subplot(heat[row, layer], sharex=column_axes[0] if column_axes else None)
            image = axes.imshow(matrix, cmap=WEIGHT_COLOURMAP, vmin=-limit, vmax=limit, aspect="auto",
                                interpolation="nearest")
            _label_matrix(axes, inputs, outputs, bottom=row == len(labels) - 1)
            axes.set_title(f"{label} ({run.policies[label][1]}): layer {layer + 1}, "
                           f"{matrix.shape[0]} x {matrix.shape[1]}", fontsize=10)
            column_axes.append(axes)
        figure.colorbar(image, ax=column_axes, label="weight (dimensionless)", shrink=0.9, pad=0.01)
        _weight_histogram(figure.add_subplot(histograms[0, layer]), labels, matrices, layer)
    title = f"{run.name}: weights of the {run.kind} policy (inputs normalised, biases not shown)"
    if len(labels) == 2:
        change = max(float(np.abs(a - b).max()) for a, b in zip(*weights.values(), strict=True))
        title += (f"\ncolour scale shared by BC and {labels[1]} per layer; largest change {labels[1]} - BC: "
                  f"{change:.3g}")
    figure.suptitle(title)
    return figure


def weight_matrices(policy: Policy) -> list[np.ndarray]:
    """Each layer's weight matrix (outputs, inputs); the layout is documented in sumo_rail/drivers/policies.py."""
    return list(_unflatten(policy.shape, policy.parameters)[0::2])  # W, b per layer: the even entries are the W


def _layer_axes(shape: PolicyShape, observation_names: list[str],
                layer: int) -> tuple[tuple[str, list[str]], tuple[str, list[str]]]:
    """(axis title, tick labels) of a layer's inputs and of its outputs."""
    features, actions = ("observation feature", observation_names), ("action", list(ACTION_NAMES))
    hidden = ("hidden unit", [f"h{unit}" for unit in range(shape.hidden)])
    if shape.kind == "linear":
        return features, actions
    return (features, hidden) if layer == 0 else (hidden, actions)


def _label_matrix(axes: Axes, inputs: tuple[str, list[str]], outputs: tuple[str, list[str]], bottom: bool) -> None:
    """Outputs on y, inputs on x (named only on the bottom row); thin lines between observation feature groups."""
    (input_title, input_names), (output_title, output_names) = inputs, outputs
    axes.set_yticks(range(len(output_names)), output_names, fontsize=8)
    axes.set_ylabel(output_title)
    small = len(input_names) > 20
    axes.set_xticks(range(len(input_names)), input_names, rotation=90 if small else 0, fontsize=6.5 if small else 8)
    axes.tick_params(axis="x", labelbottom=bottom, length=2)
    if bottom:
        axes.set_xlabel(input_title)
    groups = [name.rstrip("0123456789").rstrip("_") for name in input_names]
    for index in range(1, len(groups)):
        if groups[index] != groups[index - 1] and input_title == "observation feature":
            axes.axvline(index - 0.5, color="black", linewidth=0.6)


def _weight_histogram(axes: Axes, labels: list[str], matrices: list[np.ndarray], layer: int) -> None:
    values = [matrix.ravel() for matrix in matrices]
    bins = np.histogram_bin_edges(np.concatenate(values), bins=int(np.clip(values[0].size // 5, 10, 40)))
    axes.hist(values, bins=bins.tolist(), label=labels, color=[POLICY_COLOURS[label] for label in labels])
    axes.set(xlabel="weight (dimensionless)", ylabel="number of weights",
             title=f"layer {layer + 1}: distribution of its {values[0].size} weights")
    axes.legend(fontsize=9)
    _grid(axes, axis="y")


def _figure(width_in: float, height_in: float) -> Figure:
    """A figure of the given size in inches on the Agg canvas, with constrained layout."""
    figure = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _colour(index: int) -> str:
    return f"C{index % 10}"


def _marker(log: pd.DataFrame) -> str:
    """Dots on short curves, where single iterations matter; none on long ones."""
    return "o" if len(log) <= 40 else ""


def _grid(axes: Axes, axis: Literal["both", "x", "y"] = "both") -> None:
    axes.grid(True, axis=axis, linewidth=0.5, alpha=0.5)
