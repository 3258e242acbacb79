"""sumo-gui under a virtual X display (Xvfb, the `display` fixture of tests/conftest.py): an episode runs to its end,
the view follows the ego, evaluate --gui writes its row."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from PIL import Image
from sumo_rail_cli.main import cli

from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.sumo_api import SimulationError

SMALL = ["--set", "scenario.length_m=1500", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "env.ego_start_min_m=300", "--set", "env.ego_start_max_m=500"]


def test_gui_episode_runs_to_its_end_and_the_view_follows_the_red_ego(display, monkeypatch, small_config, tmp_path):
    monkeypatch.setenv("DISPLAY", display)
    env = HighwayEnv(small_config, render_mode="human", gui_delay_ms=0)
    try:
        env.reset(seed=2)
        shots = []
        terminated = truncated = False
        while not (terminated or truncated):
            if env.metrics.decisions in (5, 25):
                shots.append(tmp_path / f"view_{env.metrics.decisions}.png")
                env.gui_screenshot(shots[-1])
            _, _, terminated, truncated, info = env.step(0)
        assert info["termination"] in ("end_of_road", "collision")
        assert env.metrics.decisions > 25
    finally:
        env.close()
    for shot in shots:
        pixels = np.asarray(Image.open(shot).convert("RGB")).astype(int)
        height, width, _ = pixels.shape
        centre = pixels[height // 2 - 150:height // 2 + 150, width // 2 - 120:width // 2 + 120]
        red = (centre[..., 0] > 180) & (centre[..., 1] < 60) & (centre[..., 2] < 60)
        assert red.sum() > 30, f"{shot.name}: no red ego at the centre of the view"


def test_evaluate_gui_completes_the_episode_and_writes_its_row(display, tmp_path):
    out = tmp_path / "gui.parquet"
    command = [sys.executable, "-m", "sumo_rail_cli", "evaluate", "--policy", "expert", "--episodes", "3", "--gui",
               "--gui-delay", "0", *SMALL, "--out", str(out)]
    try:  # a hang (sumo-gui waiting to be started again after a load) fails here instead of blocking the suite
        result = subprocess.run(command, env={**os.environ, "DISPLAY": display}, capture_output=True, text=True,
                                timeout=600)
    except subprocess.TimeoutExpired:
        pytest.fail("evaluate --gui did not finish its episode within 10 minutes")
    assert result.returncode == 0, result.stderr
    table = pq.read_table(out).to_pandas()
    assert len(table) == 1 and table.loc[0, "steps"] > 10  # --gui runs one episode
    assert table.loc[0, "termination"] in ("end_of_road", "collision", "time_limit")
    assert gui_processes(display) == []  # the window closed with the episode


def gui_processes(display: str) -> list[int]:
    """Process ids of the sumo-gui processes alive on `display` (this module's private Xvfb)."""
    found = []
    for environ in Path("/proc").glob("[0-9]*/environ"):
        try:
            name = (environ.parent / "comm").read_text().strip()
            variables = environ.read_bytes().split(b"\0")
            state = (environ.parent / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if name.startswith("sumo-gui") and f"DISPLAY={display}".encode() in variables and state != "Z":
            found.append(int(environ.parent.name))
    return found


def test_gui_processes_sees_a_running_sumo_gui(display, monkeypatch, small_config):
    monkeypatch.setenv("DISPLAY", display)
    env = HighwayEnv(small_config, render_mode="human", gui_delay_ms=0)
    try:
        env.reset(seed=1)
        assert len(gui_processes(display)) == 1
    finally:
        env.close()
    assert gui_processes(display) == []


def test_a_display_no_x_server_answers_is_said(monkeypatch, small_config):
    """DISPLAY names a display no X server holds: sumo-gui quits at once, and the reset says why in one sentence."""
    monkeypatch.setenv("DISPLAY", ":9973")
    env = HighwayEnv(small_config, render_mode="human")
    with pytest.raises(SimulationError, match=r"^sumo-gui did not start \(is a display available\?\): "):
        env.reset(seed=0)
    env.close()


def test_gui_delay_without_gui_is_a_usage_error():
    result = CliRunner().invoke(cli, ["evaluate", "--gui-delay", "50"])
    assert result.exit_code == 2 and "--gui-delay needs --gui" in result.output
