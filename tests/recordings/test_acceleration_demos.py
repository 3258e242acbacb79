"""Recorded demonstrations on the acceleration interface: each period's acceleration in its bin, the env's
observation with the last commanded acceleration and the track's own history; train takes them, a run of the other
interface refuses them, and the learned policy drives a seat of the scene."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from test_recorded_demos import SMALL, invoke, two_car_scene

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.actions import Lateral, acceleration_action
from sumo_rail.sim.observation import control_slot, observation_space

ACCELERATION = ("--set", "actions.interface=acceleration")
HISTORY = ("--set", "observation.history=2")
CONFIG = Config.from_dict({"actions": {"interface": "acceleration"}, "observation": {"history": 2},
                           "scenario": {"speed_limit_mps": 44.44}, "env": {"v_max_mps": 44.44}})


@pytest.fixture(scope="module")
def scene_and_demos(tmp_path_factory):
    """The two-car scene (a car at 25 m/s for 2 s, then +2 m/s^2 for 2 s, behind a truck) and its demonstrations."""
    folder = tmp_path_factory.mktemp("acceleration_demos")
    two_car_scene(folder / "scene")
    demos = folder / "demos.parquet"
    result = invoke("recorded-demos", str(folder / "scene"), *ACCELERATION, *HISTORY, "--out", str(demos))
    assert result.exit_code == 0, result.output
    return folder / "scene", demos


def test_each_period_is_its_acceleration_with_the_last_command_and_the_tracks_past_in_view(scene_and_demos):
    _, demos = scene_and_demos
    read = read_demonstrations(demos, observation_space(CONFIG).shape[0], interface=CONFIG.actions)
    actions = CONFIG.actions
    car = read.episodes == read.episodes[0]  # the car's episode comes first (vehicles in id order)
    keep, speed_up = (acceleration_action(actions.nearest_bin(a), Lateral.KEEP, actions) for a in (0.0, 2.0))
    assert list(read.actions[car]) == [keep] * 4 + [speed_up] * 4
    slot = read.observations[car][:, control_slot(CONFIG)]
    np.testing.assert_allclose(slot, [6 / 9] * 5 + [8 / 9] * 3, atol=1e-6)  # 0 m/s^2 until one +2 was commanded
    history = read.observations[car][:, -6:]
    np.testing.assert_allclose(history[7, [0, 3]], [26.0 / 44.44, 25.0 / 44.44], atol=1e-6)  # 1 s, 2 s before 3.5 s
    metadata = read_metadata(demos)
    assert metadata["config"]["actions"]["interface"] == "acceleration"
    assert metadata["recorded_scene"]["set_point"] == "the speed at the instant (what an acceleration of 0 holds)"


def test_the_printout_counts_each_period_as_the_paper_action_it_amounts_to(tmp_path):
    """The car keeps its speed for 4 periods and speeds up for 4, the truck keeps its speed for 8: 12 keep and 4
    accelerate, not the counts of the acceleration interface's actions 0 to 4 (the lowest bins)."""
    two_car_scene(tmp_path / "scene")
    result = invoke("recorded-demos", str(tmp_path / "scene"), *ACCELERATION, "--out", str(tmp_path / "demos.parquet"))
    assert result.exit_code == 0, result.output
    assert "actions: 12 keep, 4 accelerate, 0 decelerate, 0 lane_left, 0 lane_right (a lane change" in result.output


def test_a_run_of_the_other_interface_refuses_them_before_any_work(scene_and_demos, tmp_path):
    _, demos = scene_and_demos
    result = invoke("train", *SMALL, *HISTORY, "--demos", str(demos), "--iterations", "1", "--out",
                    str(tmp_path / "rail"))
    assert result.exit_code == 2 and "holds demonstrations of the acceleration interface" in result.output
    assert "this run uses the paper interface" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "rail").exists()


def test_bc_learns_them_and_its_policy_drives_a_seat_of_the_scene(scene_and_demos, tmp_path):
    scene, demos = scene_and_demos
    result = invoke("train", *SMALL, *ACCELERATION, *HISTORY, "--demos", str(demos), "--iterations", "1",
                    "--set", "rail.directions=2", "--set", "rail.top=1", "--set", "bc.epochs=1", "--eval-every",
                    "1", "--eval-episodes", "1", "--out", str(tmp_path / "rail"))
    assert result.exit_code == 0, result.output
    held_out = tmp_path / "scene"  # the same scene with its vehicles held out for the test split
    shutil.copytree(scene, held_out)
    split = pd.read_parquet(held_out / "split.parquet").assign(split="test")
    split.to_parquet(held_out / "split.parquet", index=False)
    out = tmp_path / "seats.parquet"
    result = invoke("evaluate-scene", str(held_out), *ACCELERATION, *HISTORY, "--policy",
                    str(tmp_path / "rail" / "policy_bc.npz"), "--policy", "keep", "--policy", "sumo-idm",
                    "--seats", "1", "--horizon-s", "1", "--lead-s", "1", "--out", str(out))
    assert result.exit_code == 0, result.output
    seats = pd.read_parquet(out)
    assert set(seats["policy"]) >= {"keep", "sumo-idm"} and len(seats) == 3 * 2  # three drivers, two modes


def test_fine_bins_whose_actions_pass_127_are_written_and_read_back(tmp_path):
    """0.05 m/s^2 bins from -6 to 3 m/s^2: 181 bins, 543 actions; the car's +2 m/s^2 is action 160."""
    two_car_scene(tmp_path / "scene")
    fine = ("--set", "actions.acceleration_bin_mps2=0.05")
    result = invoke("recorded-demos", str(tmp_path / "scene"), *ACCELERATION, *fine, "--out",
                    str(tmp_path / "demos.parquet"))
    assert result.exit_code == 0, result.output
    actions = Config.from_dict({"actions": {"interface": "acceleration", "acceleration_bin_mps2": 0.05}}).actions
    read = read_demonstrations(tmp_path / "demos.parquet", interface=actions)
    speed_up = acceleration_action(actions.nearest_bin(2.0), Lateral.KEEP, actions)
    assert speed_up > 127 and list(read.actions[read.episodes == read.episodes[0]])[-4:] == [speed_up] * 4
