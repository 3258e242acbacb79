"""The closed-loop human-likeness tables of drivers in recorded drivers' seats (`scene_evaluation`'s outputs).

A method is one driver or several training runs of one (one policy per training seed, every run in the same seats);
each cell is the method's estimate with its 95% interval (`statistics.seeded_interval`: over training runs and seats;
a share's within [0, 1]; or, as an option, `statistics.hierarchical_interval`: one bootstrap of seeds and seats),
each difference row the paired difference of two methods, seat by seat and training seed by training seed (a
reference of one run, a baseline, paired with each of the method's runs). The distributions table gives the
Wasserstein-1 distance between a method's and the humans' samples of speed, acceleration, gap to the leader and the
gap to the new leader taken at lane changes, with an interval from resampling whole episodes
(`human_likeness.wasserstein_interval`; a method's training runs' episodes pooled), and each difference row how much
farther one method is from the humans than another, resampling whole seats
(`human_likeness.paired_wasserstein_interval`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from sumo_rail.evaluation.human_likeness import HORIZONS_S, paired_wasserstein_interval, wasserstein_interval
from sumo_rail.evaluation.statistics import Interval, Sample, hierarchical_interval, seeded_interval

if TYPE_CHECKING:
    from sumo_rail.config import Config
    from sumo_rail.evaluation.protocol import Evaluation

HUMAN = "human"
"""The driver name of the recorded vehicles' own rows (`scene_evaluation.evaluate_seats`)."""
SEAT_KEYS = ["mode", "scene", "vehicle", "start_s"]
MEASURES: dict[str, str] = {
    **{f"position error {h:g} s [m]": f"position_error_{h:g}s_m" for h in HORIZONS_S},
    "position RMSE [m]": "position_rmse_m", "speed RMSE [m/s]": "speed_rmse_mps",
    "collisions": "collided", "at fault": "at_fault", "stops": "stopped", "progress vs human": "progress_ratio",
    "lane changes / km": "lane_changes_per_km", "hard braking / episode": "hard_braking",
    "TTC < 1.5 s share": "ttc_below_1_5s_share", "driving score": "driving_score",
}
"""Table heading -> the measure (`samples`); a table leaves out those no episode defines (`defined_measures`: a
horizon beyond the seats' length, a measure older evaluations did not record)."""
SHARES = frozenset({"collided", "at_fault", "stopped", "ttc_below_1_5s_share", "driving_score"})
"""The measures that are shares, in [0, 1], whose intervals stay there (`statistics.seeded_interval`'s `share`)."""
DISTRIBUTIONS = {"speed [m/s]": "speed", "acceleration [m/s^2]": "acceleration", "jerk [m/s^3]": "jerk",
                 "gap to leader [m]": "gap", "time headway [s]": "headway", "lane-change gap [m]": "lane_change_gap"}


def samples(episodes: pd.DataFrame, measure: str) -> Sample:
    """One (numerator, denominator) per episode of `measure`: a mean over the episodes where it is defined, lane
    changes per km driven, the TTC share per decision."""
    if measure == "lane_changes_per_km":
        return episodes["lane_changes"].to_numpy(float), np.maximum(episodes["distance_m"].to_numpy(float), 0) / 1e3
    if measure == "ttc_below_1_5s_share":
        steps = episodes["steps"].to_numpy(float)
        return episodes[measure].to_numpy(float) * steps, steps
    if measure == "collided":
        values = (episodes["collisions"] > 0).to_numpy(float)
    elif measure == "at_fault":
        values = (episodes["at_fault_collisions"] > 0).to_numpy(float)
    else:
        values = episodes[measure].to_numpy(float)
    defined = ~np.isnan(values)
    return np.where(defined, values, 0.0), defined.astype(float)


def defined_measures(metrics: pd.DataFrame, measures: Mapping[str, str]) -> dict[str, str]:
    """The `measures` some episode of `metrics` defines (its column recorded and not NaN everywhere)."""
    def defined(measure: str) -> bool:
        try:
            return bool(samples(metrics, measure)[1].any())
        except KeyError:
            return False
    return {heading: measure for heading, measure in measures.items() if defined(measure)}


def _runs(metrics: pd.DataFrame, names: Sequence[str], mode: str) -> list[pd.DataFrame]:
    """Each run's episodes in `mode`, in the same seat order."""
    return [metrics[(metrics["policy"] == name) & (metrics["mode"] == mode)].sort_values(SEAT_KEYS) for name in names]


def track_table(metrics: pd.DataFrame, methods: Mapping[str, Sequence[str]],
                differences: Sequence[tuple[str, str]] = (), measures: Mapping[str, str] = MEASURES,
                hierarchical: bool = False) -> str:
    """The `measures` (heading -> a column of `metrics`, or one `samples` makes) of every method in every mode, then
    each (method, reference) difference; a measure no episode defines is left out, and the table is empty ("") when
    none is (no episodes); with `hierarchical` the intervals resample training seeds and seats together
    (`statistics.hierarchical_interval`) instead of `seeded_interval`'s t factor on the seeds."""
    measures = defined_measures(metrics, measures)
    if not measures:  # a heading without columns is no table
        return ""
    pooled = _hierarchical if hierarchical else seeded_interval
    lines = ["| driver | mode | " + " | ".join(measures) + " |", "|---|---|" + "---|" * len(measures)]
    modes = sorted(metrics["mode"].unique())
    for mode in modes:
        for method, names in methods.items():
            runs = _runs(metrics, names, mode)
            cells = [pooled([samples(run, measure) for run in runs], share=measure in SHARES).format(2)
                     for measure in measures.values()]
            lines.append(f"| {method} | {mode} | " + " | ".join(cells) + " |")
        for method, reference in differences:
            runs, others = _runs(metrics, methods[method], mode), _runs(metrics, methods[reference], mode)
            others = others * len(runs) if len(others) == 1 else others
            cells = [_starred(pooled([samples(run, measure) for run in runs],
                                     [samples(run, measure) for run in others], share=measure in SHARES))
                     for measure in measures.values()]
            lines.append(f"| {method} - {reference} | {mode} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _hierarchical(sample: Sequence[Sample], reference: Sequence[Sample] | None = None, share: bool = False) -> Interval:
    """`hierarchical_interval` (a bootstrap's interval stays within a share's range by itself)."""
    return hierarchical_interval(sample, reference)


def _starred(difference: Interval) -> str:
    return difference.format(2, signed=True) + (" *" if difference.excludes_zero else "")


def distribution_samples(track: pd.DataFrame, period_s: float) -> dict[str, np.ndarray]:
    """One episode's (or one human's) samples: speeds, accelerations and jerks between decisions, gaps to the leader,
    time headways (the gap over the speed, while moving faster than 1 m/s) and the gaps at lane changes (the gap in
    the new lane at the first decision there)."""
    speed = track["speed_mps"].to_numpy(float)
    lane = track["lane"].to_numpy()
    gap = track["gap_m"].to_numpy(float)
    changed = np.flatnonzero(np.diff(lane) != 0) + 1
    acceleration = np.diff(speed) / period_s
    headway = np.divide(gap, speed, out=np.full_like(gap, np.nan), where=speed > 1.0)
    return {"speed": speed, "acceleration": acceleration, "jerk": np.diff(acceleration) / period_s, "gap": gap,
            "headway": headway, "lane_change_gap": gap[changed]}


def distribution_table(tracks: pd.DataFrame, methods: Mapping[str, Sequence[str]], period_s: float,
                       differences: Sequence[tuple[str, str]] = ()) -> str:
    """The Wasserstein-1 distance of every method's samples to the humans' of the same seats and mode, then each
    (method, reference) difference of those distances, paired by seat."""
    lines = ["| driver | mode | " + " | ".join(DISTRIBUTIONS) + " |", "|---|---|" + "---|" * len(DISTRIBUTIONS)]
    by_episode = {key: distribution_samples(group, period_s)
                  for key, group in tracks.groupby(["policy", *SEAT_KEYS], sort=True)}
    for mode in sorted(tracks["mode"].unique()):
        humans = {key[1:]: values for key, values in by_episode.items() if key[0] == HUMAN and key[1] == mode}
        for method, names in methods.items():
            ours = [values for key, values in by_episode.items() if key[0] in names and key[1] == mode]
            cells = [wasserstein_interval([episode[name] for episode in ours],
                                          [episode[name] for episode in humans.values()]).format(2)
                     for name in DISTRIBUTIONS.values()]
            lines.append(f"| {method} | {mode} | " + " | ".join(cells) + " |")
        for method, reference in differences:
            seated = [[_seat_samples(by_episode, methods[driver], seat) for seat in humans]
                      for driver in (method, reference)]
            cells = [_starred(paired_wasserstein_interval([seat[name] for seat in seated[0]],
                                                          [seat[name] for seat in seated[1]],
                                                          [human[name] for human in humans.values()]))
                     for name in DISTRIBUTIONS.values()]
            lines.append(f"| {method} - {reference} | {mode} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _seat_samples(by_episode: Mapping[tuple, dict[str, np.ndarray]], names: Sequence[str],
                  seat: tuple) -> dict[str, np.ndarray]:
    """A method's samples in one seat (a (mode, *SEAT_KEYS) key): its training runs' episodes there pooled."""
    episodes = [by_episode[(name, *seat)] for name in names if (name, *seat) in by_episode]
    return {name: np.concatenate([episode[name] for episode in episodes]) if episodes else np.empty(0)
            for name in DISTRIBUTIONS.values()}


DISTANCE_INTERVALS = ("A distance's interval is the middle 95% of the distances between resampled seats' samples; "
                      "resampling adds noise that lengthens a distance, so an interval may lie above its estimate: "
                      "compare drivers by the paired differences and the floor.")
"""What every table of `distribution_table`'s distances says of their intervals (`wasserstein_interval`)."""


def seats_summary(evaluation: Evaluation, config: Config, reference: str | None = None,
                  expert: str | None = None) -> str:
    """Recorded seats' tables (`protocol.summarise`): every driver's `track_table`, then its `distribution_table`
    (the seats are their own reference: the humans')."""
    methods = {name: [name] for name in dict.fromkeys(evaluation.metrics["policy"])}
    distances = distribution_table(evaluation.decisions, methods, config.env.decision_period_s)
    return (f"{track_table(evaluation.metrics, methods)}\n\nWasserstein-1 distance to the humans' distributions. "
            f"{DISTANCE_INTERVALS}\n\n{distances}")
