"""Closed-loop human-likeness (docs/results.md, "Learning from recorded drivers"): the tables of
`sumo-rail evaluate-scene`'s episodes, each learner pooled over its three training seeds and paired seat by seat.

- the closed loop of experiments/specs/human_likeness_closed_loop.toml (the paper's interface): BC, RAIL and GAIL,
  RAIL and GAIL each paired with the BC of the same seed;
- the acceleration interface (`--study acceleration`, experiments/specs/human_likeness_acceleration.toml): each BC
  setting found in the episodes (runs named acceleration_hH_pP_sSEED: observation.history H s, bc.class_balance
  0.P), paired with SUMO's IDM and with the constant speed (keep) in the same seats, on the position errors and on
  the distributions' distances, and then by the seat's phase: the seats that begin within `ENTRY_M` of the road's
  entry (the drivers still speeding up towards a desired speed the observation does not show) and the others, with
  where the driver is along the road and how fast against the human at 10 s. Several files (one evaluation per
  observation layout) are read as one; a driver found in more than one (the baselines) is taken from the first.

    python experiments/human_likeness_closed_loop.py CLOSED_LOOP.parquet
    python experiments/human_likeness_closed_loop.py --study acceleration EPISODES.parquet [EPISODES.parquet ...]
    python experiments/human_likeness_closed_loop.py --study log EPISODES.parquet [EPISODES.parquet ...]

- training against the log (`--study log`, experiments/specs/human_likeness_log.toml): BC and `dagger --expert log`
  (runs named log_tT_sSEED: teacher horizon T s) against every baseline found (keep, SUMO's IDM, the calibrated IDM)
  and against BC, with the same distributions, floor and phase tables; RAIL in recorded seats
  (experiments/specs/human_likeness_rail_seats.toml, runs named rail_seats_aSTEP_sSEED) and GAIL in recorded seats
  (experiments/specs/human_likeness_gail_seats.toml, runs named gail_seats_lRATE_sSEED) the same, and against
  training against the log too. Files read as one as above (RAIL's or GAIL's evaluation beside the log study's, on
  the same seats).

`--intervals hierarchical` gives the track tables' intervals from one bootstrap of training seeds and seats
(`statistics.hierarchical_interval`) instead of the committed tables' t factor on the seeds.
"""

from __future__ import annotations

import re
from pathlib import Path

import click
import numpy as np
import pandas as pd

from sumo_rail.datasets import read_metadata
from sumo_rail.evaluation.human_floor import floor_table
from sumo_rail.evaluation.scene_evaluation import HUMAN, tracks_path
from sumo_rail.evaluation.scene_summary import DISTANCE_INTERVALS, SEAT_KEYS, distribution_table, track_table

SEEDS = (0, 1, 2)
KEEP, IDM = "constant set-point (keep)", "SUMO's IDM + LC2013"
METHODS = {KEEP: ["keep"], IDM: ["sumo-idm"],
           "rule-based expert": ["expert-normal"], "BC": [f"rail_s{seed}/policy_bc" for seed in SEEDS],
           "RAIL": [f"rail_s{seed}/policy_latest" for seed in SEEDS],
           "GAIL": [f"gail_s{seed}/policy_latest" for seed in SEEDS]}
DIFFERENCES = [("RAIL", "BC"), ("GAIL", "BC")]
ACCELERATION_RUN = re.compile(r"acceleration_h(\d+)_p(\d+)_s(\d+)/policy_bc")
"""The BC policies of the acceleration study: acceleration_hH_pP_sSEED/policy_bc."""
LOG_RUN = re.compile(r"log_t(\d+)(?:_h(\d+))?_s(\d+)/policy_(bc|latest)"
                     r"(?: \((sampled(?: at [0-9.]+)?|expected|median)\))?")
"""The runs of the log study: log_tT_sSEED (dagger --expert log, teacher horizon T s; log_tT_hH_sSEED with
observation.history=H s): its BC and its last policy,
acting by argmax or, named so, by another decoding (`--set actions.decoding=expected`) or drawing each action from
its softmax (`--policy sampled:PATH`; "sampled at T" below a temperature of 1)."""
HISTORY = re.compile(r", history \d+ s")
"""The history a log-study learner was shown, in its name (compared with the same learner shown none)."""
OTHER_READING = re.compile(r", (sampled( at [0-9.]+)?|expected|median)$")
"""A log-study learner read otherwise than by argmax, compared with its argmax reading."""
RAIL_SEATS_RUN = re.compile(r"rail_seats_a(\d+)_s(\d+)/policy_latest")
"""RAIL in recorded seats (experiments/specs/human_likeness_rail_seats.toml): rail_seats_aSTEP_sSEED, its step size
0.STEP."""
GAIL_SEATS_RUN = re.compile(r"gail_seats_l(\d+)_s(\d+)/policy_latest")
"""GAIL in recorded seats (experiments/specs/human_likeness_gail_seats.toml): gail_seats_lRATE_sSEED, PPO's learning
rate 0.RATE."""
IN_SEATS = {"RAIL in seats, step": RAIL_SEATS_RUN, "GAIL in seats, learning rate": GAIL_SEATS_RUN}
"""The learners trained in recorded seats, each named by its one setting, and their runs' names."""
CALIBRATED = "IDM calibrated on the train split"
ENTRY_M = 300.0
"""A seat that begins within this distance of the road's entry [m] is in the entering phase."""
HORIZON_S = 10.0
"""Where the phase table reads the driver's place and speed against the human's [s after the seat's start]."""
PHASE_MEASURES = {"position error 5 s [m]": "position_error_5s_m", "position error 10 s [m]": "position_error_10s_m",
                  "ahead of the human at 10 s [m]": "ahead_10s_m", "faster than the human at 10 s [m/s]":
                  "faster_10s_mps"}


def acceleration_methods(policies: set[str]) -> dict[str, list[str]]:
    """The constant speed, SUMO's IDM and each BC setting of `policies` with its training runs (seeds in order)."""
    settings: dict[tuple[int, str], list[tuple[int, str]]] = {}
    for policy in policies:
        if found := ACCELERATION_RUN.fullmatch(policy):
            settings.setdefault((int(found[1]), found[2]), []).append((int(found[3]), policy))
    methods = {"constant speed (keep)": ["keep"], IDM: ["sumo-idm"]}
    for (history, balance), runs in sorted(settings.items()):
        methods[f"BC, history {history} s, balance {float('0.' + balance):g}"] = [name for _, name in sorted(runs)]
    return methods


def log_methods(policies: set[str]) -> dict[str, list[str]]:
    """The baselines found in `policies` (constant speed, SUMO's IDM, the calibrated IDM), BC (the first teacher's
    runs' policy_bc: BC does not depend on the teacher) and training against the log for each teacher horizon, each
    for every history the runs show, and RAIL and GAIL in recorded seats for each of their settings (`IN_SEATS`)."""
    runs: dict[tuple[str, int, int], list[tuple[int, str]]] = {}
    in_seats: dict[tuple[str, str], list[tuple[int, str]]] = {}
    for policy in policies:
        if found := LOG_RUN.fullmatch(policy):
            kind = found[4] + (f", {found[5]}" if found[5] else "")
            runs.setdefault((kind, int(found[1]), int(found[2] or 0)), []).append((int(found[3]), policy))
        for learner, pattern in IN_SEATS.items():
            if found := pattern.fullmatch(policy):
                in_seats.setdefault((learner, found[1]), []).append((int(found[2]), policy))
    methods = {name: [driver] for name, driver in (("constant speed (keep)", "keep"), (IDM, "sumo-idm"),
                                                   (CALIBRATED, "sumo-idm-calibrated")) if driver in policies}

    def seen(history: int) -> str:
        return f", history {history} s" if history else ""

    for history in sorted({history for kind, _, history in runs if kind == "bc"}):
        cloned = min(teacher for kind, teacher, shown in runs if kind == "bc" and shown == history)
        methods["BC" + seen(history)] = [name for _, name in sorted(runs[("bc", cloned, history)])]
    for teacher, history in sorted({(teacher, history) for kind, teacher, history in runs if kind == "latest"}):
        for kind in sorted(kind for kind, horizon, shown in runs
                           if kind.startswith("latest") and (horizon, shown) == (teacher, history)):
            methods[f"against the log, teacher {teacher} s{seen(history)}{kind.removeprefix('latest')}"] = [
                name for _, name in sorted(runs[(kind, teacher, history)])]
    for (learner, setting), seeds in sorted(in_seats.items()):
        methods[f"{learner} {float('0.' + setting):g}"] = [name for _, name in sorted(seeds)]
    return methods


def log_study(policies: set[str]) -> tuple[dict[str, list[str]], list[tuple[str, str]], str]:
    """`log_methods` of `policies`, the pairs the log study's tables compare (every learner against every baseline
    and BC; a learner shown a history against itself shown none; another reading against argmax; RAIL and GAIL in
    seats against training against the log) and the
    learners' description."""
    methods = log_methods(policies)
    learners = [method for method in methods if method.startswith(("BC", "against the log", "RAIL", "GAIL"))]
    baselines = [method for method in methods if method not in learners]
    differences = [(learner, baseline) for learner in learners for baseline in baselines]
    differences += [(learner, "BC") for learner in learners if learner != "BC" and "BC" in methods]
    differences += [(learner, without) for learner in learners
                    if (without := HISTORY.sub("", learner)) != learner and without in methods]
    differences += [(learner, learner.rsplit(", ", 1)[0]) for learner in learners if OTHER_READING.search(learner)]
    differences += [(seated, log) for seated in learners if seated.startswith(("RAIL", "GAIL"))
                    for log in learners if log.startswith("against the log")]
    differences = list(dict.fromkeys(differences))
    kinds = [kind for kind, prefix in (("BC", "BC"), ("training against the log", "against the log"),
                                       ("RAIL in seats", "RAIL"), ("GAIL in seats", "GAIL"))
             if any(method.startswith(prefix) for method in learners)]
    named = f"{', '.join(kinds[:-1])} and {kinds[-1]}" if len(kinds) > 1 else kinds[0]
    return methods, differences, f"{named} (acceleration interface)"


def read_episodes(paths: tuple[Path, ...]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The episodes and tracks of every file as one: a driver found in several files (the humans too) taken from the
    first."""
    metrics, tracks, seen = [], [], set()
    for path in paths:
        episodes, driven = pd.read_parquet(path), pd.read_parquet(tracks_path(path))
        new = sorted(set(episodes["policy"]) - seen)
        metrics.append(episodes[episodes["policy"].isin(new)])
        tracks.append(driven[driven["policy"].isin(new) | ((driven["policy"] == HUMAN) & (HUMAN not in seen))])
        seen |= {*new, HUMAN}
    return pd.concat(metrics, ignore_index=True), pd.concat(tracks, ignore_index=True)


def at_horizon(track: pd.DataFrame, start_s: float) -> tuple[float, float]:
    """A track's position along its lane [m] and speed [m/s] `HORIZON_S` after `start_s` [s]; NaN when it ends
    earlier (a collision)."""
    times = track["time_s"].to_numpy(float)
    if len(times) == 0 or times[-1] < start_s + HORIZON_S - 1e-6:
        return np.nan, np.nan
    return tuple(float(np.interp(start_s + HORIZON_S, times, track[column].to_numpy(float)))
                 for column in ("lane_position_m", "speed_mps"))


def with_phase(metrics: pd.DataFrame, tracks: pd.DataFrame) -> pd.DataFrame:
    """The episodes with their seat's phase (`entering`: the human's track there begins within `ENTRY_M` of the
    road's entry) and how far ahead of the human and how much faster the driver is at `HORIZON_S`."""
    humans = {key: track for key, track in tracks[tracks["policy"] == HUMAN].groupby(SEAT_KEYS)}
    driven = {key: track for key, track in tracks[tracks["policy"] != HUMAN].groupby(["policy", *SEAT_KEYS])}
    columns = []
    for row in metrics[["policy", *SEAT_KEYS]].itertuples(index=False):
        human = humans[tuple(row[1:])]
        start_s = float(human["time_s"].iloc[0])
        (ours_m, ours_mps), (theirs_m, theirs_mps) = (at_horizon(track, start_s) for track in (driven[tuple(row)],
                                                                                             human))
        columns.append((human["lane_position_m"].iloc[0] < ENTRY_M, ours_m - theirs_m, ours_mps - theirs_mps))
    return metrics.assign(**dict(zip(("entering", "ahead_10s_m", "faster_10s_mps"), zip(*columns, strict=True),
                                     strict=True)))


def phase_tables(metrics: pd.DataFrame, tracks: pd.DataFrame, methods: dict[str, list[str]],
                 differences: list[tuple[str, str]], hierarchical: bool = False) -> str:
    """The phase measures of every method in the entering seats, then in the others."""
    phased = with_phase(metrics, tracks)
    seats = phased.drop_duplicates(["scene", "vehicle", "start_s"])["entering"]
    parts = []
    for entering, label in ((True, f"entering (the seat within {ENTRY_M:g} m of the road's entry)"),
                            (False, "established (farther in)")):
        heading = f"\n{label}: {int((seats == entering).sum())} of {len(seats)} seats"
        table = track_table(phased[phased["entering"] == entering], methods, differences, PHASE_MEASURES, hierarchical)
        parts.append(f"{heading}\n\n{table}" if table else heading)  # no table of a phase without seats
    return "\n".join(parts)


@click.command()
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--study", type=click.Choice(["closed-loop", "acceleration", "log"]), default="closed-loop",
              show_default=True, help="Whose drivers: the paper interface's learners, BC on the acceleration "
                                      "interface, or BC and training against the log (dagger --expert log) on it.")
@click.option("--intervals", type=click.Choice(["t", "hierarchical"]), default="t", show_default=True,
              help="How the intervals pool the training seeds: t (the committed tables: a t factor on the seeds' "
                   "spread) or hierarchical (one bootstrap of seeds and seats, statistics.hierarchical_interval).")
def main(paths: tuple[Path, ...], study: str, intervals: str) -> None:
    metrics, tracks = read_episodes(paths)
    period = read_metadata(paths[0])["config"]["env"]["decision_period_s"]
    seats = metrics.groupby(["scene", "vehicle"]).ngroups
    if study == "closed-loop":
        methods, differences, pooled = METHODS, DIFFERENCES, "BC, RAIL and GAIL"
    elif study == "acceleration":
        methods = acceleration_methods(set(metrics["policy"]))
        learners = [method for method in methods if method.startswith("BC")]
        differences = [(learner, baseline) for learner in learners for baseline in (IDM, "constant speed (keep)")]
        pooled = "BC (acceleration interface)"
    else:
        methods, differences, pooled = log_study(set(metrics["policy"]))
    print(f"{seats} held-out cars' seats in {metrics['scene'].nunique()} scenes of SUMO's drivers, "
          f"{metrics['simulated_s'].max():g} s each; {pooled} pooled over training seeds "
          f"{', '.join(map(str, SEEDS))}; differences paired by seat and training seed (* : the interval excludes 0)\n")
    hierarchical = intervals == "hierarchical"
    print(track_table(metrics, methods, differences, hierarchical=hierarchical))
    print("\nWasserstein-1 distance to the humans' distributions (same seats)"
          + ("; differences paired by seat. " if study != "closed-loop" else ". ") + DISTANCE_INTERVALS + "\n")
    print(distribution_table(tracks, methods, period, differences if study != "closed-loop" else ()))
    if study != "closed-loop":
        print("\nThe floor: the humans of one random half of the seats against the other half's, and each driver's "
              "distance (its episodes in one half against the humans of the other) as a multiple of it, the mean "
              "over 200 splits [the middle 95% of the splits' multiples]:\n")
        print(floor_table(tracks, methods, period))
        print(f"\nBy the seat's phase (ahead of / faster than the human: the driver's place along its lane and speed "
              f"{HORIZON_S:g} s into the seat minus the human's):")
        print(phase_tables(metrics, tracks, methods, differences, hierarchical))


if __name__ == "__main__":
    main()
