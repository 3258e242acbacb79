"""Validate the action-reading rule (sumo_rail/recordings/actions.py) where the truth is known: drive the rule-based
expert in the env, keep its ego's track at every SUMO step, write the episodes as highD (25 Hz, box corners), NGSIM
(10 Hz, feet) and FCD, read them back, read the actions off the tracks and compare them with the actions the expert
took: agreement, confusion matrix, each action's recall and precision. The track read directly (SUMO's 0.1 s steps,
no file) is the first row.

Two parts kept apart (`POOLS`): validation, on which the rule's thresholds were chosen, and test, reported once.
Also: each lane change's recall over the requests that SUMO carried out, and the shares of the expert's speed
actions that no track can show (from the env's set-point). Prints Markdown; --out writes it too.

Usage: python experiments/action_rule_validation.py [--validation-episodes 80] [--test-episodes 150] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
from ego_tracks import DriverFactory, drive, original_ids, publish, round_trips, took_effect

from sumo_rail.config import Config
from sumo_rail.drivers.expert import DEFAULT_STYLE, make_expert
from sumo_rail.recordings.actions import ActionRule, read_actions
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.sumo_api import EGO_ID

LEADER_RANGE_M = 150.0
"""A leader within this distance [m] counts as one the ACC follows (in the shares of invisible set-point steps)."""
LATERAL = {Action.LANE_LEFT: 1, Action.LANE_RIGHT: -1}
"""The lane-change requests among the expert's actions (`ego_tracks.took_effect`)."""
DEAD_BANDS_MPS2 = (1.0, 1.3, 1.6, 2.0, 2.4)
"""Dead bands [m/s^2] whose readings of the validation episodes are shown beside the rule's (the trade-off)."""
POOLS = {"validation": 2000, "test": 1000}
"""The warm-state pool of each part and the first of its evaluation seeds (the rule's thresholds were chosen on
validation; test is reported once)."""


def expert_driver(config: Config) -> DriverFactory:
    """The expert, keeping its action and what the shares of invisible set-point steps need."""
    expert = make_expert(DEFAULT_STYLE, config.env.speed_step_mps, config.expert.view_range_m)

    def choose(observation: np.ndarray, env: HighwayEnv) -> tuple[int, dict]:
        action = expert(observation, env.traffic)
        sim = env.simulation
        assert sim is not None  # the episode is running
        return action, {"expert": action, "lateral": LATERAL.get(action, 0), "speed_mps": env.traffic.ego.speed_mps,
                        "set_point_mps": env.traffic.set_point_mps,
                        "leader_speed_mps": sim.leader_speed_mps(EGO_ID, LEADER_RANGE_M)}

    return lambda seed: choose


def period_speeds(tracks: pd.DataFrame, expert: pd.DataFrame, period_s: float) -> pd.DataFrame:
    """The expert's rows with each period's speed at its start and end [m/s], from the track as driven."""
    parts = []
    for vehicle, rows in expert.groupby("vehicle_id", sort=False):
        track = tracks[tracks["vehicle_id"] == vehicle]
        time_s, speed = track["time_s"].to_numpy(), track["speed_mps"].to_numpy()
        instants = time_s[0] + period_s * rows["decision"].to_numpy()
        parts.append(rows.assign(v_start=np.interp(instants, time_s, speed),
                                 v_end=np.interp(instants + period_s, time_s, speed)))
    return pd.concat(parts)


def invisible_shares(speeds: pd.DataFrame, read: pd.DataFrame, rule: ActionRule) -> str:
    """Why speed actions are missed or misread, from the env's set-point and the ego's leader (the truth a track
    lacks); `read`: the actions read off the track as driven, by vehicle_id and decision."""
    both = speeds.merge(read, on=["vehicle_id", "decision"])
    below = both["set_point_mps"] > both["v_start"] + rule.set_point_tolerance_mps
    held = both["leader_speed_mps"] < both["set_point_mps"] + rule.speed_step_mps  # slower than the step asks for
    expert, action = both["expert"], both["action"]
    accelerates, keeps = expert == Action.ACCELERATE, expert == Action.KEEP
    missed = accelerates & (action == Action.KEEP)
    as_decelerate, as_accelerate = keeps & (action == Action.DECELERATE), keeps & (action == Action.ACCELERATE)
    following = both["leader_speed_mps"] < both["set_point_mps"]
    return (f"Behind a leader within {LEADER_RANGE_M:.0f} m slower than the set-point an accelerate asks for (where "
            f"the ACC cannot follow the step, or not for long): {np.mean(held[accelerates]):.2f} of the expert's "
            f"{accelerates.sum()} accelerates, "
            f"{(held & missed).sum()} of the {missed.sum()} read as keep. Behind such a leader (the ACC braking for "
            f"it): {(following & as_decelerate).sum()} of the {as_decelerate.sum()} keeps read as decelerate. More "
            f"than {rule.set_point_tolerance_mps} m/s below the set-point (the ACC catching up on a set-point the "
            f"track had not shown): {(below & as_accelerate).sum()} of the {as_accelerate.sum()} keeps read as "
            f"accelerate.")


def compare(expert: pd.DataFrame, read: pd.DataFrame, names: dict[str, str]) -> tuple[dict, np.ndarray]:
    """Agreement, recall and precision per action, the lane changes' recall over the requests that took effect
    (`expert["took_effect"]`), and the confusion matrix (rows: the expert's, columns: read)."""
    read = read.assign(decision=read.groupby("vehicle_id").cumcount(), vehicle_id=read["vehicle_id"].map(names))
    both = expert.merge(read, on=["vehicle_id", "decision"], how="inner")
    matrix = np.zeros((len(Action), len(Action)), dtype=np.int64)
    np.add.at(matrix, (both["expert"].to_numpy(), both["action"].to_numpy()), 1)
    summary = {"decisions": len(both), "agreement": np.trace(matrix) / max(matrix.sum(), 1)}
    for action in Action:
        summary[f"{action.name.lower()} recall"] = matrix[action, action] / max(matrix[action].sum(), 1)
        summary[f"{action.name.lower()} precision"] = matrix[action, action] / max(matrix[:, action].sum(), 1)
    for action in (Action.LANE_LEFT, Action.LANE_RIGHT):
        done = both[(both["expert"] == action) & both["took_effect"]]
        summary[f"{action.name.lower()} recall, took effect"] = np.mean(done["action"] == action)
    return summary, matrix


def report(config: Config, pool: str, episodes: int, rule: ActionRule) -> list[str]:
    """The Markdown section of one pool: its table over the four tracks, its confusion matrix and shares."""
    seeds = [int(seed) for seed in episode_seeds(Purpose.EVALUATE, POOLS[pool], episodes)]
    tracks, expert, net_file = drive(config, seeds, pool, expert_driver(config))
    expert = expert.assign(took_effect=took_effect(tracks, expert, rule.decision_period_s))
    requested = expert["expert"].isin([Action.LANE_LEFT, Action.LANE_RIGHT])
    lines = [f"## {pool.capitalize()}: {episodes} episodes from the {pool} pool's warm states (evaluation seeds from "
             f"{POOLS[pool]}), {len(expert)} decisions\n",
             "Expert's actions: " + ", ".join(f"{action.name.lower()} {np.mean(expert['expert'] == action):.3f}"
                                               for action in Action)
             + f". Lane-change requests that took effect: {expert['took_effect'].sum()} of {requested.sum()}.\n"]
    with tempfile.TemporaryDirectory() as folder:
        read_back = round_trips(tracks, net_file, config.scenario.lanes, Path(folder))
    header = None
    for source, scene in read_back.items():
        summary, matrix = compare(expert, read_actions(scene, rule, lateral=True), original_ids(scene, tracks))
        if header is None:
            header = list(summary)
            lines += ["| track | " + " | ".join(header) + " |", "|---|" + "---:|" * len(header)]
        lines.append(f"| {source} | " + " | ".join(f"{summary[key]:.3f}" if isinstance(summary[key], float)
                                                   else str(summary[key]) for key in header) + " |")
        if source.startswith("SUMO"):
            confusion = matrix
    names = [action.name.lower() for action in Action]
    lines += ["", "Confusion matrix of the track read directly (rows: the expert's action, columns: the action read):",
              "", "| expert \\ read | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names)]
    lines += [f"| {names[i]} | " + " | ".join(str(value) for value in confusion[i]) + " |" for i in range(len(names))]
    if pool == "validation":
        lines += ["", "The dead band's trade-off (the track read directly):", "",
                  "| dead band [m/s^2] | agreement | accelerate recall | accelerate precision | decelerate recall | "
                  "decelerate precision |", "|---:|---:|---:|---:|---:|---:|"]
        for band in DEAD_BANDS_MPS2:
            summary, _ = compare(expert, read_actions(tracks, replace(rule, dead_band_mps2=band), lateral=True),
                                 {vehicle: vehicle for vehicle in tracks["vehicle_id"].unique()})
            lines.append(f"| {band} | " + " | ".join(f"{summary[key]:.3f}" for key in (
                "agreement", "accelerate recall", "accelerate precision", "decelerate recall", "decelerate precision"))
                + " |")
    read = read_actions(tracks, rule, lateral=True)
    read = read.assign(decision=read.groupby("vehicle_id").cumcount())
    return [*lines, "", invisible_shares(period_speeds(tracks, expert, rule.decision_period_s), read, rule), ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--validation-episodes", type=int, default=80)
    parser.add_argument("--test-episodes", type=int, default=150)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    config = Config()
    rule = ActionRule.for_env(config.env)
    lines = ["# The action-reading rule against the expert's own actions\n",
             f"Command: `python {' '.join(sys.argv)}`. The {DEFAULT_STYLE} expert on the default straight road "
             f"({config.scenario.lanes} lanes); rule (sumo_rail/recordings/actions.py): dead band "
             f"{rule.dead_band_mps2:.3f} m/s^2, phase floor {rule.phase_floor_mps2} m/s^2, set-point step "
             f"{rule.speed_step_mps} m/s and tolerance {rule.set_point_tolerance_mps} m/s, lane-change onset "
             f"{rule.onset_speed_mps} m/s sideways.\n"]
    publish([*lines, *report(config, "validation", args.validation_episodes, rule),
             *report(config, "test", args.test_episodes, rule)], args.out)


if __name__ == "__main__":
    main()
