"""How far each driver's behaviour distributions are from the reference expert's, over the same episodes.

Continuous quantities use the Wasserstein-1 distance (scipy.stats.wasserstein_distance, in the quantity's own
unit: how far, on average, probability mass must move); categorical ones the total variation distance
(half the L1 distance between the two frequency vectors, from 0 = identical to 1 = disjoint).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.distance import cityblock
from scipy.stats import wasserstein_distance

from sumo_rail.evaluation.safety import HEADWAY_CAP_S
from sumo_rail.sim.actions import Action

CONTINUOUS: dict[str, tuple[str, float]] = {
    "speed_w1_kmh": ("speed_mps", 3.6),
    "set_point_w1_kmh": ("set_point_mps", 3.6),
    "headway_w1_s": ("headway_s", 1.0),
    "accepted_front_gap_w1_m": ("accepted_front_gap_m", 1.0),
    "accepted_rear_gap_w1_m": ("accepted_rear_gap_m", 1.0),
}
"""Distance column -> (decision column, unit factor). NaN values (no leader, no accepted lane change) are left out."""
DISTANCE_COLUMNS = ("speed_w1_kmh", "set_point_w1_kmh", "headway_w1_s", "no_leader_share_difference",
                    "lane_tv", "action_tv", "accepted_front_gap_w1_m", "accepted_rear_gap_w1_m")


def distances(driver: pd.DataFrame, reference: pd.DataFrame, lanes: int) -> dict[str, float]:
    """Distances between one driver's decision records and the reference's (columns of DECISION_FIELDS)."""
    row: dict[str, float] = {}
    for name, (column, factor) in CONTINUOUS.items():
        ours, theirs = driver[column].dropna().to_numpy(), reference[column].dropna().to_numpy()
        row[name] = factor * wasserstein_distance(ours, theirs) if len(ours) and len(theirs) else np.nan
    row["no_leader_share_difference"] = float(driver["headway_s"].isna().mean() - reference["headway_s"].isna().mean())
    row["lane_tv"] = _total_variation(driver["lane"], reference["lane"], lanes)
    row["action_tv"] = _total_variation(driver["action"], reference["action"], len(Action))
    return {name: row[name] for name in DISTANCE_COLUMNS}


def distance_table(decisions: pd.DataFrame, reference: str, lanes: int) -> pd.DataFrame:
    """One row per driver other than `reference` (column 'policy' of `decisions`), DISTANCE_COLUMNS."""
    groups = dict(tuple(decisions.groupby("policy", sort=False)))
    if reference not in groups:
        raise ValueError(f"no decisions of the reference driver {reference!r}")
    rows = {name: distances(frame, groups[reference], lanes) for name, frame in groups.items() if name != reference}
    return pd.DataFrame.from_dict(rows, orient="index", columns=list(DISTANCE_COLUMNS))


def frequencies(values: pd.Series, categories: int, lowest: int = 0) -> np.ndarray:
    """Share of each category lowest..categories-1 (route lanes start at -1 where a road has an acceleration lane or
    a ramp)."""
    counts = np.bincount(values.to_numpy(dtype=np.int64) - lowest, minlength=categories - lowest)[:categories - lowest]
    return counts / max(counts.sum(), 1)


def _total_variation(ours: pd.Series, theirs: pd.Series, categories: int) -> float:
    lowest = int(min(0, ours.to_numpy().min(initial=0), theirs.to_numpy().min(initial=0)))
    return 0.5 * cityblock(frequencies(ours, categories, lowest), frequencies(theirs, categories, lowest))


SPEED_BINS_KMH = np.linspace(0, 130, 27)
"""Bins of the speed histogram (km/h) a decision summary keeps and the report draws."""
HEADWAY_BINS = 21
"""Edges of the time-headway histogram, from 0 to HEADWAY_CAP_S (decisions with a leader)."""


def summary_path(metrics_path: Path) -> Path:
    """Where the decision summary of a metrics file goes: NAME.distributions.parquet beside NAME.parquet."""
    return Path(metrics_path).with_suffix(".distributions.parquet")


def decision_summary(decisions: pd.DataFrame, reference: str, lanes: int) -> pd.DataFrame:
    """What the tables and the report's figure read of the per-decision records, one row per driver (in order of
    appearance; index: the driver): DISTANCE_COLUMNS to `reference` (NaN on its own row), then the driver's counts of
    decisions in each speed bin (speed_bin_K, SPEED_BINS_KMH) and time-headway bin (headway_bin_K) and its share of
    decisions in each of `lanes` lanes (lane_K). A few kilobytes in place of the records' megabytes; `distance_table`
    and the report's behaviour distributions read the same numbers from either."""
    groups = dict(tuple(decisions.groupby("policy", sort=False)))
    if reference not in groups:
        raise ValueError(f"no decisions of the reference driver {reference!r}")
    headway_bins = np.linspace(0, HEADWAY_CAP_S, HEADWAY_BINS)
    rows = {}
    for name, frame in groups.items():
        row = (distances(frame, groups[reference], lanes) if name != reference
               else dict.fromkeys(DISTANCE_COLUMNS, np.nan))
        speed = np.histogram(frame["speed_mps"] * 3.6, SPEED_BINS_KMH)[0]
        headway = np.histogram(frame["headway_s"].dropna(), headway_bins)[0]
        row |= {f"speed_bin_{k}": int(count) for k, count in enumerate(speed)}
        row |= {f"headway_bin_{k}": int(count) for k, count in enumerate(headway)}
        row |= {f"lane_{k}": share for k, share in enumerate(frequencies(frame["lane"], lanes))}
        rows[name] = row
    summary = pd.DataFrame.from_dict(rows, orient="index")
    summary.index.name = "policy"
    return summary


def summary_distances(summary: pd.DataFrame, reference: str) -> pd.DataFrame:
    """`distance_table` read from a `decision_summary`: every driver but `reference`, DISTANCE_COLUMNS."""
    if reference not in summary.index:
        raise ValueError(f"no decisions of the reference driver {reference!r}")
    table = summary.loc[summary.index != reference, list(DISTANCE_COLUMNS)]
    table.index.name = None
    return table
