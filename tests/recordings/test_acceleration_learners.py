"""GAIL and RAIL on the acceleration interface, end to end on recorded demonstrations: each learns from a scene's
demonstrations, saves a policy of the interface's 111 actions that moved from BC, and that policy drives a seat of
the scene with evaluate-scene."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from test_recorded_demos import SMALL, invoke, two_car_scene

from sumo_rail.drivers.policies import load_policy

ACCELERATION = ("--set", "actions.interface=acceleration")


@pytest.fixture(scope="module")
def scene_and_demos(tmp_path_factory):
    folder = tmp_path_factory.mktemp("acceleration_learners")
    two_car_scene(folder / "scene")
    demos = folder / "demos.parquet"
    result = invoke("recorded-demos", str(folder / "scene"), *ACCELERATION, "--out", str(demos))
    assert result.exit_code == 0, result.output
    held_out = folder / "held_out"  # the same scene with its vehicles in the test split, for the seats
    shutil.copytree(folder / "scene", held_out)
    pd.read_parquet(held_out / "split.parquet").assign(split="test").to_parquet(held_out / "split.parquet",
                                                                              index=False)
    return held_out, demos


def drives_a_seat(scene, policy, tmp_path) -> None:
    out = tmp_path / "seats.parquet"
    result = invoke("evaluate-scene", str(scene), *ACCELERATION, "--policy", str(policy), "--seats", "1",
                    "--horizon-s", "1", "--lead-s", "1", "--mode", "non-reactive", "--out", str(out))
    assert result.exit_code == 0, result.output
    seats = pd.read_parquet(out)
    assert len(seats) == 1 and np.isfinite(seats["position_error_1s_m"]).all()


def moved_from_bc(run) -> bool:
    bc, _ = load_policy(run / "policy_bc.npz")
    latest, _ = load_policy(run / "policy_latest.npz")
    assert bc.shape.actions == latest.shape.actions == 3 * 37  # lane decision x acceleration bins
    return not np.array_equal(bc.parameters, latest.parameters)


@pytest.mark.parametrize(("command", "options"), [
    ("train", ["--iterations", "1", "--set", "rail.directions=2", "--set", "rail.top=1", "--eval-every", "0"]),
    ("gail", ["--timesteps", "64", "--set", "gail.n_steps=32", "--set", "gail.envs=1", "--set",
              "gail.critic_warmup=0"]),
])
def test_rail_and_gail_learn_from_recorded_demonstrations_on_the_acceleration_interface(scene_and_demos, tmp_path,
                                                                                        command, options):
    if command == "gail":
        pytest.importorskip("stable_baselines3", reason="gail is the package's optional extra [baselines]")
    scene, demos = scene_and_demos
    run = tmp_path / command
    result = invoke(command, *SMALL, *ACCELERATION, "--demos", str(demos), *options, "--set", "bc.epochs=1",
                    "--out", str(run))
    assert result.exit_code == 0, result.output
    assert moved_from_bc(run)
    drives_a_seat(scene, run / "policy_latest.npz", tmp_path)
