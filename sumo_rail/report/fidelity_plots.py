"""The report's figures of imitation fidelity: agreement with the expert, confusion matrices, behaviour
distributions against the expert's, and paired differences (a forest plot)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from sumo_rail.evaluation.distributions import HEADWAY_BINS, SPEED_BINS_KMH
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS
from sumo_rail.evaluation.fidelity import ACTION_NAMES, CONFUSION_COLUMNS, HEADWAY_CAP_S, RATES
from sumo_rail.evaluation.summary import MEASURES
from sumo_rail.report.plots import _colour, _figure, _grid

RATE_LABELS = {"agreement": "agreement", "lane_change_recall": "lane-change\nrecall",
               "lane_change_precision": "lane-change\nprecision", "lateral_agreement": "lateral\nagreement",
               "longitudinal_agreement": "longitudinal\nagreement"}
MEASURE_UNITS = {"average_speed_kmh": "km/h", "distance_m": "m", "steps": "decisions", "overtakes": "per episode",
                 "lane_changes": "per episode", "collisions": "per episode", "hard_braking": "per episode",
                 "invalid_actions": "per episode", "longitudinal_reward": "sum per episode",
                 "lateral_reward": "sum per episode", "failures": "share of episodes", "merges": "per episode",
                 "seconds_per_merge": "s", "missed_exits": "per episode", "lane_end_stops": "per episode",
                 **dict.fromkeys(RATES, "share of decisions")}


def agreement_bars(intervals: pd.DataFrame) -> Figure:
    """Each agreement rate per driver with its 95% interval (rows of `evaluation.summary.intervals`)."""
    rates = intervals[intervals["measure"].isin(list(RATES))]
    drivers = list(dict.fromkeys(rates["policy"]))
    figure = _figure(max(8.0, 1.6 * len(RATES) * max(1, len(drivers)) / 2), 5.0)
    axes = figure.add_subplot()
    width = 0.8 / len(drivers)
    for index, driver in enumerate(drivers):
        rows = rates[rates["policy"] == driver].set_index("measure").reindex(list(RATES))
        positions = np.arange(len(RATES)) + (index - (len(drivers) - 1) / 2) * width
        errors = np.vstack([rows["estimate"] - rows["low"], rows["high"] - rows["estimate"]])
        axes.bar(positions, rows["estimate"].fillna(0), width, yerr=np.nan_to_num(errors), capsize=3,
                 color=_colour(index), label=driver, error_kw={"elinewidth": 1})
    axes.set_xticks(np.arange(len(RATES)), [RATE_LABELS[name] for name in RATES])
    axes.set(ylim=(0, 1.05), ylabel="share (0-1)",
             title="On-policy agreement with the expert at the driver's own decisions (95% interval)")
    axes.legend(fontsize=9)
    _grid(axes, axis="y")
    return figure


def confusion_maps(metrics: pd.DataFrame) -> Figure:
    """Per driver, the share of the expert's choices the driver made (rows: driver action; columns: expert action;
    each column sums to 1 over the decisions where the expert would have chosen that action)."""
    drivers = list(dict.fromkeys(metrics["policy"]))
    columns = min(len(drivers), 3)
    rows = -(-len(drivers) // columns)
    figure = _figure(4.3 * columns + 1.0, 4.0 * rows)
    panels = np.atleast_1d(figure.subplots(rows, columns)).ravel()
    image = None
    for axes, driver in zip(panels, drivers, strict=False):
        counts = metrics.loc[metrics["policy"] == driver, list(CONFUSION_COLUMNS)].sum().to_numpy().reshape(5, 5)
        with np.errstate(invalid="ignore", divide="ignore"):
            shares = counts / counts.sum(axis=0, keepdims=True)
        image = axes.imshow(shares, vmin=0, vmax=1, cmap="viridis")
        for (row, column), count in np.ndenumerate(counts):
            if count:
                axes.text(column, row, f"{count}", ha="center", va="center", fontsize=7,
                          color="white" if shares[row, column] < 0.6 else "black")
        axes.set_xticks(range(5), ACTION_NAMES, rotation=35, ha="right", fontsize=8)
        axes.set_yticks(range(5), ACTION_NAMES, fontsize=8)
        axes.set(xlabel="expert action", ylabel="driver action", title=driver)
    for axes in panels[len(drivers):]:
        axes.set_visible(False)
    if image is not None:
        figure.colorbar(image, ax=list(panels[:len(drivers)]),
                        label="share of the expert's column (numbers: decisions)")
    figure.suptitle("Confusion: what the driver did (rows) where the expert would have done (columns)")
    return figure


def behaviour_distributions(summary: pd.DataFrame, reference: str) -> Figure:
    """Speed, time headway and lane occupancy of every driver (lines) over the reference expert's (grey bars), from a
    decision summary (`evaluation.distributions.decision_summary`: each driver's histogram counts and lane shares)."""
    drivers = [driver for driver in summary.index if driver != reference]
    lanes = sum(column.removeprefix("lane_").isdigit() for column in summary.columns)  # lane_K, not lane_tv
    figure = _figure(15, 4.8)
    speed, headway, lane = figure.subplots(1, 3)
    panels = ((speed, "speed_bin_", SPEED_BINS_KMH, "speed (km/h)"),
              (headway, "headway_bin_", np.linspace(0, HEADWAY_CAP_S, HEADWAY_BINS),
               f"time headway to the leader (s; capped at {HEADWAY_CAP_S:g}, decisions with a leader)"))
    for axes, prefix, bins, label in panels:
        def counts(driver: str, prefix: str = prefix, bins: np.ndarray = bins) -> np.ndarray:
            return summary.loc[driver, [f"{prefix}{k}" for k in range(len(bins) - 1)]].to_numpy(dtype=float)

        middles = (bins[:-1] + bins[1:]) / 2  # one weighted value a bin draws the histogram of its decisions
        axes.hist(middles, bins=bins, weights=counts(reference), density=True, color="lightgrey",
                  label=f"{reference}")
        for index, driver in enumerate(drivers):
            axes.hist(middles, bins=bins, weights=counts(driver), density=True, histtype="step", linewidth=1.6,
                      color=_colour(index), label=driver)
        axes.set(xlabel=label, ylabel="density (per unit of x)")
        _grid(axes, axis="y")
    positions = np.arange(lanes)
    width = 0.8 / (len(drivers) + 1)

    def shares(driver: str) -> np.ndarray:
        return summary.loc[driver, [f"lane_{k}" for k in range(lanes)]].to_numpy(dtype=float)

    lane.bar(positions - 0.4 + width / 2, shares(reference), width, color="lightgrey", label=reference)
    for index, driver in enumerate(drivers):
        lane.bar(positions - 0.4 + width * (index + 1.5), shares(driver), width, color=_colour(index), label=driver)
    lane.set_xticks(positions, [f"{k}" + (" (right)" if k == 0 else "") for k in positions])
    lane.set(xlabel="lane occupied (0 = rightmost)", ylabel="share of decisions")
    _grid(lane, axis="y")
    speed.legend(fontsize=8)
    figure.suptitle(f"Behaviour distributions at every decision: each driver against {reference} (grey)")
    return figure


def forest_plot(differences: pd.DataFrame, reference: str) -> Figure:
    """Paired differences to `reference` with 95% intervals, one panel per measure (rows of
    `evaluation.summary.paired_differences`); filled markers: the interval excludes 0."""
    parts = set(SCORE_COLUMNS[1:])  # the driving score's parts stay in the tables; its panel is the score
    measures = [measure for measure in MEASURES if measure in set(differences["measure"]) and measure not in parts]
    drivers = list(dict.fromkeys(differences["policy"]))
    columns = 3
    rows = -(-len(measures) // columns)
    figure = _figure(14, 0.5 + rows * (0.45 * len(drivers) + 1.3))
    panels = np.atleast_1d(figure.subplots(rows, columns)).ravel()
    for axes, measure in zip(panels, measures, strict=False):
        frame = differences[differences["measure"] == measure].set_index("policy").reindex(drivers)
        positions = np.arange(len(drivers))[::-1]
        for index, (position, (_, row)) in enumerate(zip(positions, frame.iterrows(), strict=True)):
            colour = _colour(index)
            axes.plot([row["low"], row["high"]], [position, position], color=colour, linewidth=2)
            axes.plot(row["estimate"], position, "o", color=colour,
                      markerfacecolor=colour if row["detectable"] is True else "white")
        axes.axvline(0, color="black", linewidth=0.8)
        axes.set_yticks(positions, drivers, fontsize=8)
        axes.set(title=measure.replace("_", " "), xlabel=f"difference ({MEASURE_UNITS.get(measure, '')})")
        _grid(axes, axis="x")
    for axes in panels[len(measures):]:
        axes.set_visible(False)
    figure.suptitle(f"Paired difference to {reference} on the same seeds (95% interval; filled: excludes 0)")
    return figure
