"""Watching drivers in recorded seats: evaluate-scene --video films every episode; a scene's env drives a seat in
sumo-gui (under the `display` fixture's Xvfb), as the generated road's does."""

from __future__ import annotations

import gymnasium
import numpy as np
import pandas as pd
from click.testing import CliRunner
from sumo_rail_cli.main import cli

import sumo_rail
from sumo_rail.runners.video import read_frames
from sumo_rail.sim.observers import VehicleCapture
from sumo_rail.sim.render import EGO

CONFIG = {"observation": {"lane_block": 1}, "env": {"max_episode_s": 8.0}, "actions": {"interface": "acceleration"}}
SEATS = ["--set", "observation.lane_block=1", "--set", "scenario.lanes=3", "--set", "scenario.speed_limit_mps=44.44",
         "--set", "env.v_max_mps=50", "--seats", "2", "--horizon-s", "6", "--lead-s", "2"]


def test_every_vehicle_can_be_watched_at_every_step_while_the_replay_removes_vehicles(drivers_scene):
    """The replay removes the vehicles that leave the ego's radius or whose track ends; an every-step capture's
    subscriptions (`observers.VehicleRows`) go with them instead of failing SUMO's next step."""
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, config=CONFIG, lead_s=2.0,
                         transport="libsumo").unwrapped  # traci drops a removed vehicle's subscription itself
    try:
        for seed in range(3):
            capture = VehicleCapture(every_step=True)
            env.reset(seed=seed)
            with env.watching(capture):
                steps = 0
                while not any(env.step(0)[2:4]):
                    steps += 1
            rows = pd.DataFrame(capture.columns)
            assert capture.moments > 5 * steps  # every SUMO step of every decision (0.5 s)
            assert (rows.groupby("frame")["vehicle_id"].nunique() > 1).all()
    finally:
        env.close()


def test_evaluate_scene_films_every_episode(drivers_scene, tmp_path):
    videos, out = tmp_path / "videos", tmp_path / "seats.parquet"
    result = CliRunner().invoke(cli, ["evaluate-scene", str(drivers_scene), *SEATS, "--policy", "keep", "--policy",
                                      "sumo-idm", "--video", str(videos), "--out", str(out)])
    assert result.exit_code == 0, result.output
    metrics = pd.read_parquet(out)
    names = {f"{driver}_{mode}_episode{index:03d}_seed{index}.mp4" for driver in ("keep", "sumo-idm")
             for mode in ("non-reactive", "reactive") for index in range(2)}
    assert {path.name for path in videos.iterdir()} == names
    first = metrics[(metrics["policy"] == "keep") & (metrics["mode"] == "reactive")].iloc[0]
    frames = read_frames(videos / "keep_reactive_episode000_seed0.mp4")
    assert len(frames) == first["steps"] + 1  # the seat's first view, then one frame per decision
    near_ego = np.abs(frames[len(frames) // 2].astype(int) - np.array(EGO)).sum(axis=2) < 60
    assert near_ego.sum() > 20  # the red ego drawn in the seat
    again = CliRunner().invoke(cli, ["evaluate-scene", str(drivers_scene), *SEATS, "--policy", "keep", "--video",
                                     str(videos)])
    assert again.exit_code == 2 and "--overwrite" in again.output and "Traceback" not in again.output


def test_a_scene_env_drives_a_seat_in_sumo_gui(display, drivers_scene, monkeypatch):
    monkeypatch.setenv("DISPLAY", display)
    env = gymnasium.make(sumo_rail.SCENE_ENV_ID, scene=drivers_scene, render_mode="human", gui_delay_ms=0,
                         lead_s=2.0, config={"observation": {"lane_block": 1}, "env": {"max_episode_s": 6.0}})
    try:
        _, info = env.reset(seed=1)
        steps, terminated, truncated = 0, False, False
        while not (terminated or truncated):
            _, _, terminated, truncated, _ = env.step(0)
            steps += 1
        assert info["vehicle"] and steps > 5
    finally:
        env.close()
