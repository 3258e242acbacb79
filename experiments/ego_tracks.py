"""Env episodes whose ego's track is kept at every SUMO step, written as highD (25 Hz, box corners), NGSIM (10 Hz,
feet) and FCD and read back: what the validations of the action readings share (action_rule_validation.py for the
paper's actions, acceleration_reading_validation.py for the acceleration interface's).

A driver is made per episode from its seed (`DriverFactory`) and returns, at each decision, its action and what to
keep of it (a row of the decisions table, with "lateral": +1 a lane change to the left asked for, -1 to the right, 0
none; `took_effect` reads it).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import write_bytes_atomically
from sumo_rail.recordings import fcd, highd, ngsim
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import read_lanes
from sumo_rail.sim import network
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observers import Rows, VehicleCapture
from sumo_rail.sim.sumo_api import EGO_ID

EPISODE_GAP_S = 1000.0
"""Each episode's track is shifted by this much times its index [s], so that the episodes never share a frame."""
TOOK_EFFECT_S = 2.0
"""A lane-change request took effect when the ego's lane index changed that way within this time [s] after it (the
marking is crossed about halfway through scenario.lane_change_duration_s, 2 s) and it was the last such request
before the crossing (a request repeated at the next decision is the one SUMO carried out)."""

Driver = Callable[[np.ndarray, HighwayEnv], tuple[int, dict]]
"""(observation, env) -> (action, the decision's row: "lateral" and whatever else the validation keeps)."""
DriverFactory = Callable[[int], Driver]
"""The driver of one episode, from the episode's seed."""


TRACK_COLUMNS = ("time_s", "x_m", "y_m", "heading_deg", "speed_mps", "acceleration_mps2", "edge", "lane",
                 "lane_position_m", "length_m", "width_m", "vehicle_class")
"""The columns of an ego's track as driven (a scene's track columns but the vehicle id, added per episode)."""


def ego_rows(columns: Rows, shift_s: float) -> pd.DataFrame:
    """The ego's rows among every vehicle's (`VehicleCapture.columns`, or one moment's rows with a "time_s" column),
    its times shifted by `shift_s` [s] and kept to the microsecond (Python's rounding)."""
    frame = pd.DataFrame(columns)
    ego = frame[frame["vehicle_id"] == EGO_ID]
    return ego.assign(time_s=[round(time_s + shift_s, 6) for time_s in ego["time_s"]])[list(TRACK_COLUMNS)]


def drive(config: Config, seeds: list[int], pool: str, drivers: DriverFactory
          ) -> tuple[pd.DataFrame, pd.DataFrame, Path]:
    """The ego's tracks (one vehicle per episode, "ep000" on, every SUMO step, episode i shifted by i x
    `EPISODE_GAP_S`) and its decisions (vehicle_id, decision and the driver's row), from the warm states of `pool`."""
    env = HighwayEnv(config)
    tracks, decisions = [], []
    for index, seed in enumerate(seeds):
        driver = drivers(seed)
        observation, _ = env.reset(seed=seed, options={"pool": pool})
        sim = env.simulation
        assert sim is not None  # a reset starts it
        start_s = sim.time_s
        vehicle, shift_s = f"ep{index:03d}", index * EPISODE_GAP_S - start_s
        first = ego_rows({**sim.vehicle_rows(), "time_s": start_s}, shift_s)
        with sim.watching(VehicleCapture(every_step=True)) as capture:
            decision, done = 0, False
            while not done:
                action, row = driver(observation, env)
                decisions.append({"vehicle_id": vehicle, "decision": decision, **row})
                observation, _, terminated, truncated, _ = env.step(action)
                decision, done = decision + 1, terminated or truncated
        tracks.append(pd.concat([first, ego_rows(capture.columns, shift_s)], ignore_index=True)
                      .assign(vehicle_id=vehicle))
    env.close()
    return pd.concat(tracks, ignore_index=True), pd.DataFrame(decisions), network.build(config.scenario).net_file


def round_trips(tracks: pd.DataFrame, net_file: Path, lanes: int, folder: Path) -> dict[str, pd.DataFrame]:
    """The tracks (on one straight edge of `net_file` along +x whose left edge is y = 0) as read back from each
    format (and as driven)."""
    edge = str(tracks["edge"].iloc[0])
    widths, length = read_lanes(net_file).widths_m[edge], read_lanes(net_file).lengths_m[edge]
    paths = highd.write(tracks, widths, length, folder / "01")
    ngsim_path = ngsim.write(tracks, lanes, folder / "trajectories.csv")
    fcd_path = fcd.write(tracks, folder / "fcd.xml.gz")
    read_ngsim = ngsim.read([ngsim_path], ReadOptions(site="us-101" if lanes == 5 else "i-80")).tracks
    return {"SUMO steps (0.1 s, no file)": tracks,
            "highD (25 Hz)": highd.read([paths[0]], ReadOptions(direction="lower")).tracks,
            "NGSIM (10 Hz, feet)": read_ngsim.assign(lane=read_ngsim["lane"] - (5 - lanes if lanes < 5 else 0)),
            "FCD": fcd.read([fcd_path], ReadOptions(network=net_file)).tracks}


def original_ids(scene: pd.DataFrame, tracks: pd.DataFrame) -> dict[str, str]:
    """Each vehicle id of a scene read back -> its id in `tracks`: the same (FCD, the track as driven), or the
    original of highD's and NGSIM's numbers (their writers number the vehicles 1, 2, ... in sorted order)."""
    originals = sorted(tracks["vehicle_id"].unique())
    read = scene["vehicle_id"].unique()
    if set(read) <= set(originals):
        return {vehicle: vehicle for vehicle in read}
    return {vehicle: originals[int(vehicle) - 1] for vehicle in read}


def took_effect(tracks: pd.DataFrame, decisions: pd.DataFrame, period_s: float) -> pd.Series:
    """Per decision: a lane-change request (`decisions["lateral"]`) that SUMO carried out (`TOOK_EFFECT_S`); False
    for the others."""
    effective = pd.Series(False, index=decisions.index)
    for vehicle, rows in decisions.groupby("vehicle_id", sort=False):
        track = tracks[tracks["vehicle_id"] == vehicle]
        time_s, lane = track["time_s"].to_numpy(), track["lane"].to_numpy()
        requests = rows[rows["lateral"] != 0]
        instants = time_s[0] + period_s * requests["decision"].to_numpy()
        for row in np.flatnonzero(np.diff(lane) != 0) + 1:
            wanted = 1 if lane[row] > lane[row - 1] else -1
            before = (instants < time_s[row]) & (instants >= time_s[row] - TOOK_EFFECT_S)
            candidates = requests.index[before & (requests["lateral"] == wanted).to_numpy()]
            if len(candidates):
                effective[candidates[-1]] = True
    return effective


def publish(lines: list[str], out: Path | None) -> None:
    """Print a table's Markdown lines and, given `out`, write them there too."""
    text = "\n".join(lines)
    print(text)
    if out is not None:
        write_bytes_atomically(out, text.encode())
