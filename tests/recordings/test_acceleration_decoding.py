"""`--set actions.decoding` from the command line: a policy file evaluated in a recorded seat acts by the run's
decoding (and says so in its name), and the paper interface refuses any decoding but argmax before any work."""

from __future__ import annotations

import numpy as np
import pandas as pd
from recording_files import SCENE_SPEED_CONFIG
from test_recorded_demos import SMALL, invoke, two_car_scene

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.sim.observation import observation_names

ACCELERATION = ("--set", "actions.interface=acceleration")
BIMODAL = np.full(3 * 37, -60.0)
BIMODAL[[24, 27, 28]] = np.log([0.4, 0.35, 0.25])
"""Logits of 0, +0.75 and +1 m/s^2 in the lane (bins 24, 27, 28): argmax 0 m/s^2, expected +0.5 m/s^2."""


def test_a_seat_driven_by_the_expected_decoding_speeds_up_where_argmax_holds_the_speed(tmp_path):
    two_car_scene(tmp_path / "scene")
    split = pd.read_parquet(tmp_path / "scene" / "split.parquet").assign(split="test")
    split.to_parquet(tmp_path / "scene" / "split.parquet", index=False)
    config = Config.from_dict({**SCENE_SPEED_CONFIG, "actions": {"interface": "acceleration"}})
    names = observation_names(config)
    shape = PolicyShape("linear", len(names), actions=len(BIMODAL))  # trained by argmax: the file holds no decoding
    parameters = np.concatenate([np.zeros(len(BIMODAL) * len(names)), BIMODAL]).astype(np.float32)
    save_policy(Policy(shape, parameters), tmp_path / "bimodal.npz", {"config": config.to_dict(),
                                                                        "observation_names": names})
    speeds = {}
    for decoding in ("argmax", "expected"):
        out = tmp_path / f"{decoding}.parquet"
        result = invoke("evaluate-scene", str(tmp_path / "scene"), *ACCELERATION, "--set",
                        f"actions.decoding={decoding}", "--policy", str(tmp_path / "bimodal.npz"), "--seats", "1",
                        "--horizon-s", "1", "--lead-s", "1", "--out", str(out))
        assert result.exit_code == 0, result.output
        tracks = pd.read_parquet(tmp_path / f"{decoding}.tracks.parquet")
        driven = tracks[(tracks["policy"] != "human") & (tracks["mode"] == "non-reactive")]
        speeds[decoding] = (set(driven["policy"]), driven["speed_mps"].to_numpy())
    assert speeds["argmax"][0] == {"bimodal"} and speeds["expected"][0] == {"bimodal (expected)"}
    np.testing.assert_array_equal(speeds["argmax"][1], 25.0)  # 0 m/s^2 holds the recorded 25 m/s
    assert np.all(np.diff(speeds["expected"][1]) > 0)  # +0.5 m/s^2 (SUMO's safe speed behind the truck may cap it)


def test_the_paper_interface_refuses_another_decoding_before_any_work(tmp_path):
    result = invoke("evaluate", *SMALL, "--set", "actions.decoding=expected", "--policy", "keep", "--episodes", "1",
                    "--out", str(tmp_path / "out.parquet"))
    assert result.exit_code == 2, result.output
    assert "actions.decoding=expected reads a lane decision and an acceleration bin" in result.output
    assert "Traceback" not in result.output and not any(tmp_path.iterdir())
