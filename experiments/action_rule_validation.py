"""Validate the action-reading rule (sumo_rail/recordings/actions.py) where the truth is known: drive the rule-based
expert in the env, keep its ego's track at every SUMO step, write the episodes as highD (25 Hz, box corners), NGSIM
(10 Hz, feet) and FCD, read them back, read the actions off the tracks and compare them with the actions the expert
took: agreement, confusion matrix, each action's recall and precision. The track read directly (SUMO's 0.1 s steps,
no file) is the first row. Prints Markdown; --out writes it too.

Usage: python experiments/action_rule_validation.py [--episodes 12] [--seed 1000] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import write_bytes_atomically
from sumo_rail.drivers.expert import DEFAULT_STYLE, make_expert
from sumo_rail.recordings import fcd, highd, ngsim
from sumo_rail.recordings.actions import ActionRule, read_actions
from sumo_rail.recordings.road import read_lanes
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.sumo_api import EGO_ID

EPISODE_GAP_S = 1000.0
"""Each episode's track is shifted by this much times its index [s], so that the episodes never share a frame."""


def ego_state(api, time_s: float) -> dict:
    vehicle = api.vehicle
    x, y = vehicle.getPosition(EGO_ID)
    return {"time_s": round(time_s, 6), "x_m": x, "y_m": y, "heading_deg": vehicle.getAngle(EGO_ID),
            "speed_mps": vehicle.getSpeed(EGO_ID), "acceleration_mps2": vehicle.getAcceleration(EGO_ID),
            "edge": vehicle.getRoadID(EGO_ID), "lane": vehicle.getLaneIndex(EGO_ID),
            "lane_position_m": vehicle.getLanePosition(EGO_ID), "length_m": vehicle.getLength(EGO_ID),
            "width_m": vehicle.getWidth(EGO_ID), "vehicle_class": "passenger"}


def drive(config: Config, seeds: list[int]) -> tuple[pd.DataFrame, pd.DataFrame, Path]:
    """The expert's tracks (one vehicle per episode, every SUMO step) and its actions (one row per decision)."""
    env = HighwayEnv(config)
    expert = make_expert(DEFAULT_STYLE, config.env.speed_step_mps, config.expert.view_range_m)
    tracks, actions = [], []
    for index, seed in enumerate(seeds):
        observation, _ = env.reset(seed=seed)
        sim = env._sim
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
            actions.append({"vehicle_id": vehicle, "decision": decision, "expert": action})
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
    read_ngsim = ngsim.read([ngsim_path], "us-101" if lanes == 5 else "i-80").tracks
    return {"SUMO steps (0.1 s, no file)": tracks, "highD (25 Hz)": highd.read([paths[0]], "lower").tracks,
            "NGSIM (10 Hz, feet)": read_ngsim.assign(lane=read_ngsim["lane"] - (5 - lanes if lanes < 5 else 0)),
            "FCD": fcd.read([fcd_path], read_lanes(net_file), net_file).tracks}


def compare(expert: pd.DataFrame, read: pd.DataFrame, names: dict[str, str]) -> tuple[dict, np.ndarray]:
    """Agreement, recall and precision per action, and the confusion matrix (rows: the expert's, columns: read)."""
    read = read.assign(decision=read.groupby("vehicle_id").cumcount(), vehicle_id=read["vehicle_id"].map(names))
    both = expert.merge(read, on=["vehicle_id", "decision"], how="inner")
    matrix = np.zeros((len(Action), len(Action)), dtype=np.int64)
    np.add.at(matrix, (both["expert"].to_numpy(), both["action"].to_numpy()), 1)
    summary = {"decisions": len(both), "agreement": np.trace(matrix) / max(matrix.sum(), 1)}
    for action in Action:
        summary[f"{action.name.lower()} recall"] = matrix[action, action] / max(matrix[action].sum(), 1)
        summary[f"{action.name.lower()} precision"] = matrix[action, action] / max(matrix[:, action].sum(), 1)
    return summary, matrix


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=12)
    parser.add_argument("--seed", type=int, default=1000)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    config = Config()
    seeds = [int(seed) for seed in episode_seeds(Purpose.EVALUATE, args.seed, args.episodes)]
    tracks, expert, net_file = drive(config, seeds)
    rule = ActionRule.for_env(config.env)
    lines = ["# The action-reading rule against the expert's own actions\n",
             f"Command: `python {' '.join(sys.argv)}`. The {DEFAULT_STYLE} expert on the default straight road "
             f"({config.scenario.lanes} lanes), {args.episodes} episodes (evaluation seeds from {args.seed}), "
             f"{len(expert)} decisions; rule: dead band {rule.dead_band_mps2:.3f} m/s^2, lane-change onset "
             f"{rule.onset_speed_mps} m/s sideways (sumo_rail/recordings/actions.py). Expert's actions: "
             + ", ".join(f"{action.name.lower()} {np.mean(expert['expert'] == action):.3f}" for action in Action)
             + ".\n"]
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
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out is not None:
        write_bytes_atomically(args.out, text.encode())


if __name__ == "__main__":
    main()
