"""The tables a reader compares drivers with: every measure's mean with its 95% interval, the paired difference
of every driver to a reference driver, and the distribution distances to the reference expert."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import pandas as pd

from sumo_rail.evaluation.distributions import distance_table
from sumo_rail.evaluation.driving_score import SCORE_COLUMNS
from sumo_rail.evaluation.fidelity import CONFUSION_COLUMNS, RATES, agreement_counts
from sumo_rail.evaluation.safety import SAFETY_MEASURES
from sumo_rail.evaluation.statistics import (
    MIN_PAIRS,
    Interval,
    Sample,
    closeness_difference,
    interval,
    mean_sample,
    paired_difference,
)

EPISODE_MEASURES = ("average_speed_kmh", "overtakes", "lane_changes", "longitudinal_reward", "lateral_reward",
                    "collisions", "hard_braking", "invalid_actions", "distance_m", "steps")
"""Episode metrics summarised by their mean over episodes (the paper's first)."""
ROUTE_MEASURES = ("failures", "merges", "seconds_per_merge", "missed_exits", "lane_end_stops")
"""The route's measures (`sumo_rail.sim.route_progress`): failures (a collision, a missed exit or a stop at a lane end
ends the episode: the share of episodes that failed), merges per episode and their mean time [s], missed exits and
lane-end stops per episode; summarised for every road with a feature (`route=True`: a missed exit counts even where
every episode left the road well), and elsewhere where an episode merged or failed (none on the straight road but
collisions, which have their own row)."""
MEASURES = (*RATES, *EPISODE_MEASURES, *ROUTE_MEASURES, *SAFETY_MEASURES, *SCORE_COLUMNS)
"""Rows of the summary: the agreement rates (pooled over decisions) first, then the episode means (the safety
measures and the driving score with its parts where a metrics file has them: files written before them do not)."""
SHARES = frozenset({*RATES, "failures", *(name for name in SAFETY_MEASURES if name.endswith("_share")),
                    *SCORE_COLUMNS})
"""The measures that are shares, in [0, 1] (`statistics.seeded_interval`'s `share`): the agreement rates, the share of
episodes that failed, the shares of decisions, and the driving score with its parts."""
DETECTABLE = "*"

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.evaluation.protocol import Evaluation


def measure_samples(episodes: pd.DataFrame, route: bool = False) -> dict[str, Sample]:
    """Each measure's (numerators, denominators) per episode; the rates only where the confusion counts exist; the
    route's measures as `route_samples` gives them."""
    samples: dict[str, Sample] = {}
    if set(CONFUSION_COLUMNS) <= set(episodes.columns):
        counts = agreement_counts(episodes[list(CONFUSION_COLUMNS)].to_numpy().reshape(-1, 5, 5))
        samples |= {name: (counts[top], counts[bottom]) for name, (top, bottom) in RATES.items()}
    samples |= {name: mean_sample(episodes[name].to_numpy()) for name in (*EPISODE_MEASURES, *SAFETY_MEASURES,
                                                                          *SCORE_COLUMNS) if name in episodes}
    return samples | route_samples(episodes, route)


def route_samples(episodes: pd.DataFrame, route: bool = False) -> dict[str, Sample]:
    """The `ROUTE_MEASURES` samples of episodes whose metrics hold them, on a road with a feature (`route`) or where
    an episode merged or failed on the route."""
    if not {"merges", "missed_exits", "lane_end_stops"} <= set(episodes.columns):
        return {}
    merges = episodes["merges"].to_numpy()
    stops = episodes["missed_exits"].to_numpy() + episodes["lane_end_stops"].to_numpy()
    if not (route or merges.any() or stops.any()):
        return {}
    failed = ((episodes["collisions"].to_numpy() > 0) | (stops > 0)).astype(float)
    samples = {"failures": mean_sample(failed), "merges": mean_sample(merges.astype(float)),
               "missed_exits": mean_sample(episodes["missed_exits"].to_numpy().astype(float)),
               "lane_end_stops": mean_sample(episodes["lane_end_stops"].to_numpy().astype(float))}
    if merges.any():
        samples["seconds_per_merge"] = (episodes["merge_time_s"].to_numpy(), merges.astype(float))
    return samples


def drivers_of(metrics: pd.DataFrame) -> list[str]:
    return list(dict.fromkeys(metrics["policy"]))


def intervals(metrics: pd.DataFrame, seed: int = 0, route: bool = False) -> pd.DataFrame:
    """Rows (policy, measure): estimate, low, high (the route's measures as `route_samples` gives them)."""
    rows = []
    for driver in drivers_of(metrics):
        for measure, sample in measure_samples(metrics[metrics["policy"] == driver], route).items():
            rows.append({"policy": driver, "measure": measure, **vars(interval(sample, seed))})
    return pd.DataFrame(rows, columns=["policy", "measure", "estimate", "low", "high"])


def experts_of(metrics: pd.DataFrame) -> dict[str, str]:
    """Whom each driver's decisions were compared with (the `reference` column), for metrics that say."""
    if "reference" not in metrics:
        return {}
    named = metrics.dropna(subset=["reference"]).groupby("policy", sort=False)["reference"].first()
    return {str(driver): str(expert) for driver, expert in named.items()}


def paired_differences(metrics: pd.DataFrame, reference: str, seed: int = 0, route: bool = False) -> pd.DataFrame:
    """Rows (policy, measure) for every driver but `reference`: the difference driver - reference on the seeds
    both drove, with its interval and whether the interval excludes 0. Agreement rates only for drivers compared
    with the same expert as `reference` (`experts_of`): agreements with two experts do not subtract."""
    if reference not in drivers_of(metrics):
        raise ValueError(f"reference driver {reference!r} is not among the evaluated drivers "
                         f"({', '.join(drivers_of(metrics))})")
    by_seed = {driver: frame.set_index("seed") for driver, frame in metrics.groupby("policy", sort=False)}
    experts = experts_of(metrics)
    rows = []
    for driver in drivers_of(metrics):
        if driver == reference:
            continue
        common = by_seed[driver].index.intersection(by_seed[reference].index).sort_values()
        ours = measure_samples(by_seed[driver].loc[common].reset_index(), route)
        theirs = measure_samples(by_seed[reference].loc[common].reset_index(), route)
        other_expert = experts.get(driver) != experts.get(reference)
        for measure in ours.keys() & theirs.keys():
            if other_expert and measure in RATES:
                continue
            difference = paired_difference(ours[measure], theirs[measure], seed)
            rows.append({"policy": driver, "measure": measure, **vars(difference),
                         "detectable": difference.excludes_zero})
    frame = pd.DataFrame(rows, columns=["policy", "measure", "estimate", "low", "high", "detectable"])
    return frame.sort_values("measure", key=lambda names: names.map(MEASURES.index), kind="stable")


def closeness(metrics: pd.DataFrame, candidate: str, baseline: str, expert: str, seed: int = 0) -> pd.DataFrame:
    """Per measure, whether `candidate` is closer to `expert` than `baseline` is, on the seeds all three drove:
    |candidate - expert| - |baseline - expert| with its interval (below 0: closer) and a verdict, "closer",
    "further" or "no detectable difference"."""
    by_seed = {driver: frame.set_index("seed") for driver, frame in metrics.groupby("policy", sort=False)}
    missing = [name for name in (candidate, baseline, expert) if name not in by_seed]
    if missing:
        raise ValueError(f"no episodes of {', '.join(missing)} among the evaluated drivers")
    common = by_seed[candidate].index.intersection(by_seed[baseline].index).intersection(by_seed[expert].index)
    samples = [measure_samples(by_seed[name].loc[common.sort_values()].reset_index())
               for name in (candidate, baseline, expert)]
    rows = []
    for measure in [name for name in MEASURES if all(name in sample for sample in samples)]:
        found = closeness_difference(samples[0][measure], samples[1][measure], samples[2][measure], seed=seed)
        verdict = ("closer" if found.high < 0 else "further" if found.low > 0 else "no detectable difference")
        rows.append({"measure": measure, **vars(found), "verdict": verdict})
    return pd.DataFrame(rows, columns=["measure", "estimate", "low", "high", "verdict"])


def summary_table(metrics: pd.DataFrame, reference: str | None = None, seed: int = 0, route: bool = False) -> str:
    """Means with 95% intervals (rows: measures; columns: drivers), then each driver's paired difference to
    `reference` (default: the first driver), a * marking the intervals that exclude 0; `route`: the metrics are of a
    road with a feature, whose route measures are shown even when no episode merged or failed."""
    drivers = drivers_of(metrics)
    episodes = metrics.groupby("policy", sort=False).size()
    experts = experts_of(metrics)
    header = "\n".join(f"{driver}: {episodes[driver]} episodes"
                       + (f", agreement with {experts[driver]}" if driver in experts else "") for driver in drivers)
    means = _grid(intervals(metrics, seed, route), drivers, lambda row: _format(row, signed=False))
    text = f"{header}\nmean [95% interval], bootstrap over episodes:\n{means.to_string()}"
    reference = reference or drivers[0]
    apart = [driver for driver in drivers if experts.get(driver) != experts.get(reference)]
    if len(drivers) > 1 and apart:
        text += (f"\n\n{', '.join(apart)} {'was' if len(apart) == 1 else 'were'} compared with another expert than "
                 f"{reference}, so {'its agreement has' if len(apart) == 1 else 'their agreements have'} no "
                 f"difference to {reference}'s below (pass --expert to compare every driver with one expert)")
    if len(drivers) > 1:
        differences = paired_differences(metrics, reference, seed, route)
        grid = _grid(differences, [driver for driver in drivers if driver != reference],
                     lambda row: _format(row, signed=True) + (f" {DETECTABLE}" if row.detectable else "  "))
        too_few = (f"; n/a: fewer than {MIN_PAIRS} seeds in common, too few for an interval"
                   if (differences["estimate"].notna() & differences["low"].isna()).any() else "")
        text += (f"\n\ndifference to {reference} on the same seeds [95% interval]; {DETECTABLE}: the interval "
                 f"excludes 0 (a detectable difference){too_few}:\n{grid.to_string()}")
    return text


def episodes_summary(evaluation: Evaluation, config: Config, reference: str | None = None,
                     expert: str | None = None) -> str:
    """Generated episodes' tables (`protocol.summarise`): `summary_table`, then, with the expert named `expert` among
    several drivers, every driver's `distance_summary` to it."""
    text = summary_table(evaluation.metrics, reference, route=config.scenario.has_route_measures)
    drivers = drivers_of(evaluation.metrics)
    if expert in drivers and len(drivers) > 1:
        text += "\n\n" + distance_summary(evaluation.decisions, expert, config.scenario.lanes)
    return text


def distance_summary(decisions: pd.DataFrame, reference: str, lanes: int) -> str:
    """Distribution distances of every driver to `reference`, as text."""
    return distance_text(distance_table(decisions, reference, lanes), reference)


def distance_text(table: pd.DataFrame, reference: str) -> str:
    """A `distance_table` as text."""
    return (f"distance of each driver's distributions to {reference}'s (Wasserstein-1 in the unit named; total "
            f"variation for lanes and actions; no-leader share: difference):\n{table.round(3).to_string()}")


def _grid(rows: pd.DataFrame, drivers: list[str], cell: Callable[[Any], str]) -> pd.DataFrame:
    measures = [measure for measure in MEASURES if measure in set(rows["measure"])]
    grid = pd.DataFrame("", index=measures, columns=drivers)
    for row in rows.itertuples():
        grid.loc[row.measure, row.policy] = cell(row)
    return grid


def _format(row: Any, signed: bool) -> str:
    digits = 3 if row.measure in RATES or row.measure.endswith("_share") else 2
    return Interval(row.estimate, row.low, row.high).format(digits, signed)
