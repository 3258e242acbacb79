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

from sumo_rail.config import Config
from sumo_rail.datasets import write_bytes_atomically
from sumo_rail.drivers.expert import DEFAULT_STYLE, make_expert
from sumo_rail.recordings import fcd, highd, ngsim
from sumo_rail.recordings.actions import ActionRule, read_actions
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import read_lanes
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.sumo_api import EGO_ID

EPISODE_GAP_S = 1000.0
"""Each episode's track is shifted by this much times its index [s], so that the episodes never share a frame."""
LEADER_RANGE_M = 150.0
"""A leader within this distance [m] counts as one the ACC follows (in the shares of invisible set-point steps)."""
TOOK_EFFECT_S = 2.0
"""A lane-change request took effect when the ego's lane index changed that way within this time [s] after it (the
marking is crossed about halfway through scenario.lane_change_duration_s, 2 s) and it was the last such request
before the crossing (a request repeated at the next decision is the one SUMO carried out)."""
DEAD_BANDS_MPS2 = (1.0, 1.3, 1.6, 2.0, 2.4)
"""Dead bands [m/s^2] whose readings of the validation episodes are shown beside the rule's (the trade-off)."""
POOLS = {"validation": 2000, "test": 1000}
"""The warm-state pool of each part and the first of its evaluation seeds (the rule's thresholds were chosen on
validation; test is reported once)."""


def ego_state(api, time_s: float) -> dict:
    vehicle = api.vehicle
    x, y = vehicle.getPosition(EGO_ID)
    return {"time_s": round(time_s, 6), "x_m": x, "y_m": y, "heading_deg": vehicle.getAngle(EGO_ID),
            "speed_mps": vehicle.getSpeed(EGO_ID), "acceleration_mps2": vehicle.getAcceleration(EGO_ID),
            "edge": vehicle.getRoadID(EGO_ID), "lane": vehicle.getLaneIndex(EGO_ID),
            "lane_position_m": vehicle.getLanePosition(EGO_ID), "length_m": vehicle.getLength(EGO_ID),
            "width_m": vehicle.getWidth(EGO_ID), "vehicle_class": "passenger"}


def drive(config: Config, seeds: list[int], pool: str) -> tuple[pd.DataFrame, pd.DataFrame, Path]:
    """The expert's tracks (one vehicle per episode, every SUMO step) and its actions (one row per decision), from
    the warm states of `pool`."""
    env = HighwayEnv(config)
    expert = make_expert(DEFAULT_STYLE, config.env.speed_step_mps, config.expert.view_range_m)
    tracks, actions = [], []
    for index, seed in enumerate(seeds):
        observation, _ = env.reset(seed=seed, options={"pool": pool})
        sim = env.simulation
        api, start_s = sim._api, sim.time_s
        vehicle, shift_s = f"ep{index:03d}", index * EPISODE_GAP_S - start_s
        rows = [ego_state(api, start_s + shift_s)]
        step = sim._calls.step.__wrapped__ if hasattr(sim._calls.step, "__wrapped__") else sim._calls.step

        def recording_step(step=step, rows=rows, shift_s=shift_s, api=api):
            step()
            if EGO_ID in api.vehicle.getIDList():
                rows.append(ego_state(api, api.simulation.getTime() + shift_s))

        recording_step.__wrapped__ = step
        sim._calls = sim._calls._replace(step=recording_step)
        decision, done = 0, False
        while not done:
            action = expert(observation, env.traffic)
            leader = api.vehicle.getLeader(EGO_ID, LEADER_RANGE_M)
            actions.append({"vehicle_id": vehicle, "decision": decision, "expert": action,
                            "speed_mps": env.traffic.ego.speed_mps, "set_point_mps": env.traffic.set_point_mps,
                            "leader_speed_mps": api.vehicle.getSpeed(leader[0]) if leader else np.inf})
            observation, _, terminated, truncated, _ = env.step(action)
            decision, done = decision + 1, terminated or truncated
        tracks.append(pd.DataFrame(rows).assign(vehicle_id=vehicle))
    net_file = sim._built.net_file
    env.close()
    return pd.concat(tracks, ignore_index=True), pd.DataFrame(actions), net_file


def round_trips(tracks: pd.DataFrame, net_file: Path, lanes: int, folder: Path) -> dict[str, pd.DataFrame]:
    """The tracks as read back from each format (and as driven)."""
    widths = read_lanes(net_file).widths_m["highway"]
    length = read_lanes(net_file).lengths_m["highway"]
    paths = highd.write(tracks, widths, length, folder / "01")
    ngsim_path = ngsim.write(tracks, lanes, folder / "trajectories.csv")
    fcd_path = fcd.write(tracks, folder / "fcd.xml.gz")
    read_ngsim = ngsim.read([ngsim_path], ReadOptions(site="us-101" if lanes == 5 else "i-80")).tracks
    return {"SUMO steps (0.1 s, no file)": tracks,
            "highD (25 Hz)": highd.read([paths[0]], ReadOptions(direction="lower")).tracks,
            "NGSIM (10 Hz, feet)": read_ngsim.assign(lane=read_ngsim["lane"] - (5 - lanes if lanes < 5 else 0)),
            "FCD": fcd.read([fcd_path], ReadOptions(network=net_file)).tracks}


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


def took_effect(tracks: pd.DataFrame, expert: pd.DataFrame, period_s: float) -> pd.Series:
    """Per expert row: a lane-change request that SUMO carried out (`TOOK_EFFECT_S`); False for the others."""
    effective = pd.Series(False, index=expert.index)
    for vehicle, rows in expert.groupby("vehicle_id", sort=False):
        track = tracks[tracks["vehicle_id"] == vehicle]
        time_s, lane = track["time_s"].to_numpy(), track["lane"].to_numpy()
        requests = rows[rows["expert"].isin([Action.LANE_LEFT, Action.LANE_RIGHT])]
        instants = time_s[0] + period_s * requests["decision"].to_numpy()
        for row in np.flatnonzero(np.diff(lane) != 0) + 1:
            wanted = Action.LANE_LEFT if lane[row] > lane[row - 1] else Action.LANE_RIGHT
            before = (instants < time_s[row]) & (instants >= time_s[row] - TOOK_EFFECT_S)
            candidates = requests.index[before & (requests["expert"] == wanted).to_numpy()]
            if len(candidates):
                effective[candidates[-1]] = True
    return effective


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
    tracks, expert, net_file = drive(config, seeds, pool)
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
        names = dict(zip(sorted(scene["vehicle_id"].unique(), key=lambda v: (len(v), v)),
                         sorted(tracks["vehicle_id"].unique()), strict=True))
        summary, matrix = compare(expert, read_actions(scene, rule, lateral=True), names)
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
    lines += report(config, "validation", args.validation_episodes, rule)
    lines += report(config, "test", args.test_episodes, rule)
    text = "\n".join(lines)
    print(text)
    if args.out is not None:
        write_bytes_atomically(args.out, text.encode())


if __name__ == "__main__":
    main()
