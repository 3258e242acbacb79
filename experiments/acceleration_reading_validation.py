"""Validate the acceleration interface's reading of a track (sumo_rail/recordings/acceleration_reading.py) where the
truth is known: drivers in SUMO whose every 0.1 s step is kept, written as highD (25 Hz), NGSIM (10 Hz, feet) and FCD,
read back, and each decision period's acceleration and lane change read off them, against what the driver did.

The drivers:
- the rule-based expert on the paper's interface (its ego's track at every SUMO step, ego_tracks.drive);
- a seeded random driver on the acceleration interface that holds a random bin for 1 to 6 periods and sometimes asks
  for a lane change (`RandomDriver`): its commanded accelerations are known;
- SUMO's own drivers, every vehicle of `record_sumo_drivers` (car following and lane changing by SUMO's models,
  captured from libsumo at every step).
The truth of a period's acceleration is its mean from SUMO's speeds at the period's ends, (v(t + T) - v(t)) / T, on
SUMO's 0.1 s steps (every track starts where SUMO's steps and highD's frames meet, `ALIGNED_S`, so the instants the
reading uses are steps); for the random driver also its command, over the periods SUMO followed it. The truth of a
lane change: the egos' requests that took effect (ego_tracks.took_effect), in the period they were made; for SUMO's
drivers, the step in which SUMO's own positions began to move sideways toward the new lane (`onsets`). On the
validation part also the readings the module could have made instead (`alternatives`).

Two parts kept apart (action_rule_validation.POOLS): validation, on which any choice is made, and test, reported once.
Prints Markdown; --out writes it too.

Usage: python experiments/acceleration_reading_validation.py [--validation-episodes 30] [--test-episodes 100]
       [--validation-sumo-s 120] [--test-sumo-s 300] [--out FILE.md]   (--test-episodes 0: the validation part only)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd
from action_rule_validation import POOLS, expert_driver
from ego_tracks import DriverFactory, drive, original_ids, publish, round_trips, took_effect

from sumo_rail.action_config import ActionConfig
from sumo_rail.config import Config
from sumo_rail.recordings.acceleration_reading import read_acceleration_track, smoothing_for
from sumo_rail.recordings.actions import ActionRule, lane_changes
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, record_sumo_drivers
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import Lateral, acceleration_action, split_acceleration_action
from sumo_rail.sim.env import HighwayEnv

FORMATS = {"SUMO steps (0.1 s, no file)": "sumo", "highD (25 Hz)": "highd", "NGSIM (10 Hz, feet)": "ngsim",
           "FCD": "fcd"}
"""Each round trip's name (ego_tracks.round_trips) -> its format's name (`smoothing_for`)."""
HOLD_PERIODS = (1, 6)
"""The random driver holds each bin for this many periods, drawn uniformly (ends included)."""
LANE_CHANGE_SHARE = 0.04
"""The share of the random driver's decisions that ask for a lane change (left or right, as likely)."""
SPEED_BAND_MPS = (15.0, 35.0)
"""Below this speed [m/s] the random driver draws only bins of 0 and above, above it only bins of 0 and below."""
FOLLOWED_MPS2 = 0.01
"""A period's command was followed when SUMO's mean acceleration over it is within this of the command [m/s^2]."""
ALIGNED_S = 0.2
"""Every SUMO driver's track is moved to start at a multiple of this [s], where SUMO's 0.1 s steps and highD's 0.04 s
frames meet, as the egos' tracks start (a track started between two frames puts every period's boundary within a
frame of a step: a lane change SUMO began in the step just before a boundary is then, on the frames, as near the
period after it, and the truth ambiguous)."""
SUMO_WARMUP_S = 120.0
"""The SUMO drivers' recordings start after this warm-up [s] (record_sumo_drivers' default)."""
NGSIM_SMOOTHINGS_S = (0.0, 0.3, 0.5, 1.0, 1.5)
"""NGSIM smoothings [s] whose readings of the validation part are shown beside the reading's own."""


class RandomDriver:
    """A seeded driver on the acceleration interface: a random bin held for `HOLD_PERIODS`, within `SPEED_BAND_MPS`,
    and a lane change asked for at `LANE_CHANGE_SHARE` of its decisions while none is under way (so that the request
    SUMO carried out is the last one before the lane's crossing, as `took_effect` takes it)."""

    def __init__(self, interface: ActionConfig, seed: int) -> None:
        self.interface, self.rng = interface, np.random.default_rng([seed, 53])
        self.held, self.left = interface.nearest_bin(0.0), 0

    def __call__(self, observation: np.ndarray, env: HighwayEnv) -> tuple[int, dict]:
        interface, rng = self.interface, self.rng
        if self.left == 0:
            speed, zero = env.traffic.ego.speed_mps, interface.nearest_bin(0.0)
            low = zero if speed < SPEED_BAND_MPS[0] else 0
            high = zero if speed > SPEED_BAND_MPS[1] else interface.acceleration_bins - 1
            self.held, self.left = int(rng.integers(low, high + 1)), int(rng.integers(HOLD_PERIODS[0],
                                                                                      HOLD_PERIODS[1] + 1))
        self.left -= 1
        lateral = Lateral.KEEP
        if rng.random() < LANE_CHANGE_SHARE and not env.traffic.ego.changing_lane:
            lateral = Lateral(int(rng.integers(1, 3)))
        return acceleration_action(self.held, lateral, interface), {
            "lateral": {Lateral.KEEP: 0, Lateral.LEFT: 1, Lateral.RIGHT: -1}[lateral],
            "commanded_mps2": interface.acceleration_mps2(self.held)}


@dataclass(frozen=True)
class Truth:
    """What a driver's tracks are read against."""

    tracks: pd.DataFrame
    """Every vehicle at every SUMO step (0.1 s)."""
    changes: pd.DataFrame
    """The lane changes: vehicle_id, time_s (an instant [s] in the period the change belongs to) and lateral (+1 left,
    -1 right)."""
    commanded: pd.DataFrame | None
    """The random driver's decisions: vehicle_id, decision and commanded_mps2."""
    net_file: Path
    note: str
    """What was driven, for the section's heading."""


def onsets(tracks: pd.DataFrame, rule: ActionRule, step_s: float) -> pd.DataFrame:
    """Every lane change of `tracks` (rows at every SUMO step): vehicle_id, time_s (the start of the step in which the
    vehicle began to move sideways toward the new lane [s], rule 1 of recordings/actions.py on SUMO's own positions)
    and lateral (+1 left, -1 right)."""
    found = []
    for vehicle, track in tracks.groupby("vehicle_id", sort=True):
        time_s = track["time_s"].to_numpy()
        found += [{"vehicle_id": vehicle, "time_s": time_s[step], "lateral": 1 if left else -1}
                  for step, left in lane_changes(time_s, track["lane"].to_numpy(), track["edge"].to_numpy(),
                                                 track["y_m"].to_numpy(), replace(rule, decision_period_s=step_s),
                                                 len(time_s) - 1)]
    return pd.DataFrame(found, columns=["vehicle_id", "time_s", "lateral"])


def ego_truth(config: Config, pool: str, episodes: int, drivers: DriverFactory, rule: ActionRule, name: str) -> Truth:
    """The egos' truth: `episodes` episodes of `drivers` from `pool`'s warm states."""
    seeds = [int(seed) for seed in episode_seeds(Purpose.EVALUATE, POOLS[pool], episodes)]
    tracks, decisions, net_file = drive(config, seeds, pool, drivers)
    effective = decisions[took_effect(tracks, decisions, rule.decision_period_s)]
    starts = tracks.groupby("vehicle_id")["time_s"].min()
    changes = effective.assign(time_s=effective["vehicle_id"].map(starts) + rule.decision_period_s
                               * effective["decision"])[["vehicle_id", "time_s", "lateral"]]
    # where SUMO began a change later than the period of the request it carried out
    moved = changes.merge(onsets(tracks, rule, config.scenario.step_length_s), on=["vehicle_id", "lateral"],
                          suffixes=("", "_onset"))
    delay = moved["time_s_onset"] - moved["time_s"]
    first = delay[delay >= -1e-6].groupby([moved["vehicle_id"], moved["time_s"]]).min()
    late = int((first >= rule.decision_period_s - 1e-6).sum())
    requested = int((decisions["lateral"] != 0).sum())
    commanded = decisions[["vehicle_id", "decision", "commanded_mps2"]] if "commanded_mps2" in decisions else None
    return Truth(tracks, changes, commanded, net_file,
                 f"{episodes} episodes of the {name} from the {pool} pool's warm states (evaluation seeds from "
                 f"{POOLS[pool]}), {len(decisions)} decisions; {len(effective)} of {requested} lane-change requests "
                 f"took effect, {late} of them begun by SUMO after the request's period")


def sumo_truth(config: Config, pool: str, duration_s: float, rule: ActionRule, folder: Path) -> Truth:
    """SUMO's drivers' truth: `duration_s` [s] of `record_sumo_drivers` with SUMO seed POOLS[pool]; their lane
    changes where SUMO's own positions began to move sideways (`onsets`)."""
    record_sumo_drivers(SumoDriversSettings(out=folder / "scene", seed=POOLS[pool], duration_s=duration_s,
                                            warmup_s=SUMO_WARMUP_S), config)
    scene, step_s = read_scene(folder / "scene"), config.scenario.step_length_s
    tracks = scene.tracks.sort_values(["vehicle_id", "time_s"], kind="stable", ignore_index=True)
    steps = np.rint(tracks.groupby("vehicle_id")["time_s"].transform("min").to_numpy() / step_s).astype(np.int64)
    shift_s = np.where(steps % round(ALIGNED_S / step_s) != 0, step_s, 0.0)
    tracks = tracks.assign(time_s=np.round(tracks["time_s"].to_numpy() - shift_s, 6))
    changes = onsets(tracks, rule, step_s)
    return Truth(tracks, changes, None, scene.network,
                 f"{duration_s:g} s of SUMO's drivers (record-sumo-drivers, SUMO seed {POOLS[pool]}, after "
                 f"{SUMO_WARMUP_S:g} s): {tracks['vehicle_id'].nunique()} vehicles, "
                 f"{len(changes)} lane changes")


def read_scene_accelerations(scene: pd.DataFrame, rule: ActionRule, interface: ActionConfig,
                             smoothing_s: float) -> pd.DataFrame:
    """vehicle_id, time_s (decision instant), the period's acceleration before binning, its bin and the lane
    decision (+1 left, -1 right, 0 keep) of every decision of every track of a scene read back."""
    parts = []
    for vehicle, track in scene.sort_values(["vehicle_id", "time_s"], kind="stable").groupby("vehicle_id", sort=True):
        instants, actions, accelerations = read_acceleration_track(
            track["time_s"].to_numpy(), track["speed_mps"].to_numpy(), track["lane"].to_numpy(),
            track["edge"].to_numpy(), track["y_m"].to_numpy(), rule, interface, smoothing_s)
        split = [split_acceleration_action(int(action), interface) for action in actions]
        parts.append(pd.DataFrame({"vehicle_id": vehicle, "time_s": instants, "acceleration_mps2": accelerations,
                                   "bin": [bin_ for bin_, _ in split],
                                   "lateral": [{Lateral.KEEP: 0, Lateral.LEFT: 1, Lateral.RIGHT: -1}[lateral]
                                               for _, lateral in split]}))
    return pd.concat(parts, ignore_index=True)


def with_truth(read: pd.DataFrame, truth: Truth, period_s: float) -> pd.DataFrame:
    """The read rows (vehicle ids those of the truth's tracks) with the truth: the decision (the nearest of the
    vehicle's instants in the truth's tracks), the period's mean acceleration from SUMO's speeds at the read instant
    and one period later (rows whose period outlasts the truth's track are dropped) and the lane change made in the
    period (true_lateral: +1 left, -1 right, 0 none)."""
    parts = []
    tracks, changes = truth.tracks.groupby("vehicle_id", sort=False), truth.changes.groupby("vehicle_id", sort=False)
    for vehicle, rows in read.groupby("vehicle_id", sort=False):
        track = tracks.get_group(vehicle)
        time_s, speed = track["time_s"].to_numpy(), track["speed_mps"].to_numpy()
        instants = rows["time_s"].to_numpy()
        true_lateral = np.zeros(len(rows), dtype=np.int64)
        if vehicle in changes.groups:
            made = changes.get_group(vehicle)
            period = np.searchsorted(instants, made["time_s"].to_numpy() + 1e-6, side="right") - 1
            within = (period >= 0) & (made["time_s"].to_numpy() < instants[np.maximum(period, 0)] + period_s - 1e-6)
            true_lateral[period[within]] = made["lateral"].to_numpy()[within]
        inside = instants + period_s <= time_s[-1] + 1e-6
        parts.append(rows.assign(
            decision=np.rint((instants - time_s[0]) / period_s).astype(np.int64), true_lateral=true_lateral,
            truth_mps2=(np.interp(instants + period_s, time_s, speed) - np.interp(instants, time_s, speed)) / period_s
        )[inside])
    return pd.concat(parts, ignore_index=True)


def measures(both: pd.DataFrame, truth: Truth, interface: ActionConfig) -> dict[str, float]:
    """The reading against the truth: periods, acceleration RMS error [m/s^2], the share in the truth's bin, for the
    random driver the same against its commands that SUMO followed, and the lane changes' recall and precision."""
    error = both["acceleration_mps2"] - both["truth_mps2"]
    truth_bins = [interface.nearest_bin(float(value)) for value in both["truth_mps2"]]
    found = {"periods": len(both), "RMS [m/s^2]": float(np.sqrt(np.mean(error ** 2))),
             "in the truth's bin": float(np.mean(both["bin"].to_numpy() == np.asarray(truth_bins)))}
    if truth.commanded is not None:
        commanded = both.merge(truth.commanded, on=["vehicle_id", "decision"])
        followed = commanded[(commanded["truth_mps2"] - commanded["commanded_mps2"]).abs() <= FOLLOWED_MPS2]
        found |= {"commands followed": len(followed) / max(len(commanded), 1),
                  "RMS to the command [m/s^2]": float(np.sqrt(np.mean((followed["acceleration_mps2"]
                                                                       - followed["commanded_mps2"]) ** 2))),
                  "in the command's bin": float(np.mean(followed["bin"].to_numpy() == np.asarray(
                      [interface.nearest_bin(float(value)) for value in followed["commanded_mps2"]])))}
    for side, sign in (("left", 1), ("right", -1)):
        wanted, got = both["true_lateral"] == sign, both["lateral"] == sign
        hits = int((wanted & got).sum())
        found |= {f"{side} changes": int(wanted.sum()), f"{side} recall": hits / max(int(wanted.sum()), 1),
                  f"{side} precision": hits / max(int(got.sum()), 1)}
    return found


def table(results: dict[str, dict[str, float]]) -> list[str]:
    header = list(next(iter(results.values())))
    lines = ["| track | " + " | ".join(header) + " |", "|---|" + "---:|" * len(header)]
    return lines + [f"| {name} | " + " | ".join(f"{value:.3f}" if isinstance(value, float) else str(value)
                                                for value in found.values()) + " |"
                    for name, found in results.items()]


def hermite_speeds(time_s: np.ndarray, speed_mps: np.ndarray, acceleration_mps2: np.ndarray,
                   at_s: np.ndarray) -> np.ndarray:
    """A track's speeds [m/s] at `at_s` [s] by cubic Hermite interpolation between its rows, with the recorded
    accelerations as the speeds' slopes (exact where the speed is quadratic between two rows)."""
    row = np.clip(np.searchsorted(time_s, at_s, side="right") - 1, 0, len(time_s) - 2)
    width = time_s[row + 1] - time_s[row]
    s = np.clip((at_s - time_s[row]) / width, 0.0, 1.0)
    return ((2 * s ** 3 - 3 * s ** 2 + 1) * speed_mps[row] + (s ** 3 - 2 * s ** 2 + s) * width * acceleration_mps2[row]
            + (3 * s ** 2 - 2 * s ** 3) * speed_mps[row + 1] + (s ** 3 - s ** 2) * width * acceleration_mps2[row + 1])


def recorded_accelerations(read: pd.DataFrame, scene: pd.DataFrame, period_s: float, how: str) -> np.ndarray:
    """Each read period's mean acceleration [m/s^2] from the scene's recorded accelerations instead of its speeds:
    "hermite", the speeds at the period's ends by `hermite_speeds`; "mean", the mean of the accelerations of the rows
    in the period (SUMO's acceleration of a row is its step's, so at every step they add up to the period's)."""
    found = []
    tracks = scene.sort_values(["vehicle_id", "time_s"], kind="stable").groupby("vehicle_id", sort=False)
    for vehicle, rows in read.groupby("vehicle_id", sort=False):
        track = tracks.get_group(vehicle)
        time_s, acceleration = track["time_s"].to_numpy(), track["acceleration_mps2"].to_numpy()
        starts = rows["time_s"].to_numpy()
        if how == "hermite":
            speed = track["speed_mps"].to_numpy()
            found.append((hermite_speeds(time_s, speed, acceleration, starts + period_s)
                          - hermite_speeds(time_s, speed, acceleration, starts)) / period_s)
        else:
            within = (time_s[None, :] > starts[:, None] + 1e-6) & (time_s[None, :] <= starts[:, None] + period_s + 1e-6)
            found.append((within * acceleration[None, :]).sum(axis=1) / np.maximum(within.sum(axis=1), 1))
    return np.concatenate(found)


def alternatives(scenes: dict[str, pd.DataFrame], truth: Truth, rule: ActionRule,
                 interface: ActionConfig) -> list[str]:
    """The table of readings the module could have made instead (the validation part's): NGSIM's speeds smoothed
    otherwise, and highD's and FCD's recorded accelerations."""
    period_s, results = rule.decision_period_s, {}
    for smoothing_s in NGSIM_SMOOTHINGS_S:
        results[f"NGSIM, speeds smoothed over {smoothing_s:g} s"] = with_truth(
            read_scene_accelerations(scenes["ngsim"], rule, interface, smoothing_s), truth, period_s)
    for format_name, how, label in (("highd", "hermite", "highD, speeds at the instants by Hermite interpolation "
                                     "with the recorded accelerations"),
                                    ("fcd", "mean", "FCD, the mean of the period's recorded accelerations")):
        read = with_truth(read_scene_accelerations(scenes[format_name], rule, interface, 0.0), truth, period_s)
        accelerations = recorded_accelerations(read, scenes[format_name], period_s, how)
        results[label] = read.assign(acceleration_mps2=accelerations,
                                     bin=[interface.nearest_bin(float(value)) for value in accelerations])
    shown = {}
    for label, both in results.items():
        found = measures(both, truth, interface)
        shown[label] = {key: value for key, value in found.items() if not key.startswith(("left", "right"))}
    return [f"Other readings (the module's: NGSIM's speeds smoothed over {smoothing_for('ngsim'):g} s, every "
            "format's speeds interpolated linearly at the instants):", "", *table(shown), ""]


def driver_section(truth: Truth, config: Config, rule: ActionRule, interface: ActionConfig, name: str,
                   validation: bool) -> list[str]:
    """One driver's table over the four tracks (and, on validation, the `alternatives`)."""
    with tempfile.TemporaryDirectory() as folder:
        read_back = round_trips(truth.tracks, truth.net_file, config.scenario.lanes, Path(folder))
    results, scenes = {}, {}
    for source, scene in read_back.items():
        scene = scene.assign(vehicle_id=scene["vehicle_id"].map(original_ids(scene, truth.tracks)))
        scenes[FORMATS[source]] = scene
        read = read_scene_accelerations(scene, rule, interface, smoothing_for(FORMATS[source]))
        results[source] = measures(with_truth(read, truth, rule.decision_period_s), truth, interface)
    lines = [f"### {name}: {truth.note}\n", *table(results), ""]
    return lines + (alternatives(scenes, truth, rule, interface) if validation else [])


def report(config: Config, pool: str, episodes: int, sumo_s: float) -> list[str]:
    """The Markdown section of one pool: a table per driver."""
    interface = ActionConfig(interface="acceleration")
    rule = ActionRule.for_env(config.env)
    accelerating = replace(config, actions=interface)
    lines = [f"## {pool.capitalize()}\n"]
    truth = ego_truth(config, pool, episodes, expert_driver(config), rule, "rule-based expert (paper interface)")
    lines += driver_section(truth, config, rule, interface, "The rule-based expert", pool == "validation")
    truth = ego_truth(accelerating, pool, episodes, lambda seed: RandomDriver(interface, seed), rule,
                      "random driver (acceleration interface)")
    lines += driver_section(truth, config, rule, interface, "The random driver", pool == "validation")
    with tempfile.TemporaryDirectory() as folder:
        truth = sumo_truth(config, pool, sumo_s, rule, Path(folder))
        lines += driver_section(truth, config, rule, interface, "SUMO's drivers", pool == "validation")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--validation-episodes", type=int, default=30)
    parser.add_argument("--test-episodes", type=int, default=100)
    parser.add_argument("--validation-sumo-s", type=float, default=120.0)
    parser.add_argument("--test-sumo-s", type=float, default=300.0)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    config = Config()
    lines = ["# The acceleration reading against what the drivers did\n",
             f"Command: `python {' '.join(sys.argv)}`. The default straight road ({config.scenario.lanes} lanes), "
             f"decision period {config.env.decision_period_s} s; the acceleration interface's defaults (bins of "
             f"{ActionConfig().acceleration_bin_mps2} m/s^2); NGSIM's speeds smoothed over "
             f"{smoothing_for('ngsim'):g} s (sumo_rail/recordings/acceleration_reading.py).\n"]
    lines += report(config, "validation", args.validation_episodes, args.validation_sumo_s)
    publish(lines + (report(config, "test", args.test_episodes, args.test_sumo_s) if args.test_episodes else []),
            args.out)


if __name__ == "__main__":
    main()
