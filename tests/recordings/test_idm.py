"""SUMO's IDM in numpy: one step is SUMO's own, step for step; the calibration recovers the parameters and desired
speeds that generated a scene, and reads a seated driver's desired speed from its lead-in alone."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.recordings.idm import IdmParameters, next_speed
from sumo_rail.recordings.idm_calibration import (
    CalibrationSettings,
    calibrate,
    fit,
    lead_in_desired_speed,
    windows_of,
)
from sumo_rail.recordings.idm_windows import scene_rows
from sumo_rail.recordings.road import build_road
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.sim.built_network import sumo_binary
from sumo_rail.sim.sumo_api import load_api

STEP_S = 0.1
TRUE = IdmParameters(accel_mps2=1.7, decel_mps2=3.1, tau_s=1.3, min_gap_m=3.2, delta=3.0)


def sumo_follower(tmp_path) -> np.ndarray:
    """A SUMO IDM follower (`TRUE`) behind a leader that speeds up and down, stops, is moved close in front of it
    (the follower brakes at its emergency deceleration) and leaves it behind; the follower's desired speed is lowered
    below its speed at 75 s. Rows per step: follower's speed, gap, leader's speed, follower's desired speed."""
    build_road([3.2, 3.2], 3000.0, tmp_path / "road.net.xml")
    vtype = " ".join(f'{key}="{value}"' for key, value in TRUE.vtype_attributes().items())
    (tmp_path / "road.rou.xml").write_text(
        f'<routes><vType id="idm" {vtype} speedFactor="0.8"/><vType id="lead" decel="9" emergencyDecel="20"/>'
        '<route id="r" edges="road"/>'
        '<vehicle id="L" type="lead" route="r" depart="0" departPos="60" departSpeed="5" departLane="0"/>'
        '<vehicle id="F" type="idm" route="r" depart="0" departPos="5" departSpeed="38" departLane="0"/></routes>')
    api = load_api("traci")  # its own SUMO process: other tests' libsumo may be open in this one
    api.start([sumo_binary("sumo"), "-n", str(tmp_path / "road.net.xml"), "-r", str(tmp_path / "road.rou.xml"),
               "--step-length", repr(STEP_S), "--no-step-log", "true", "--no-warnings", "true"])
    rows = []
    try:
        for k in range(900):
            api.simulationStep()
            time_s = k * STEP_S
            if {"L", "F"} <= set(api.vehicle.getIDList()):
                for name in ("L", "F"):
                    api.vehicle.setLaneChangeMode(name, 0)
                api.vehicle.setSpeed("L", 20 + 12 * np.sin(time_s / 4) if time_s < 30 else 0.0 if time_s < 50 else 30)
                if abs(time_s - 12) < 1e-9:
                    api.vehicle.moveTo("L", "road_0", api.vehicle.getLanePosition("F") + 40.0)
                if abs(time_s - 75) < 1e-9:
                    api.vehicle.setSpeedFactor("F", 0.5)
                rows.append((api.vehicle.getSpeed("F"), api.vehicle.getLanePosition("L")
                             - api.vehicle.getLength("L") - api.vehicle.getLanePosition("F"),
                             api.vehicle.getSpeed("L"), api.vehicle.getAllowedSpeed("F")))
    finally:
        api.close()
    return np.array(rows)


def test_one_step_is_sumos_own(tmp_path):
    """Following, free, above the desired speed and in emergency braking: SUMO's next speed, to the last bit."""
    rows = sumo_follower(tmp_path)
    speed, gap, leader, desired = rows.T
    predicted = next_speed(TRUE, speed[:-1], desired[:-1], gap[:-1], leader[:-1], STEP_S)
    np.testing.assert_allclose(predicted, speed[1:], rtol=0, atol=1e-9)
    acceleration = np.diff(speed) / STEP_S
    assert acceleration.min() == pytest.approx(-9.0)  # emergency braking after the cut-in
    assert (speed > desired + 1.0).any() and (gap > 200).any()  # above its desired speed, and nearly free


@pytest.fixture(scope="module")
def road(tmp_path_factory):
    """The straight two-lane road (edge "road") `synthetic_tracks` drive on."""
    folder = tmp_path_factory.mktemp("idm_road")
    build_road([3.2, 3.2], 4000.0, folder / "road.net.xml")
    return scene_road(folder / "road.net.xml")


def synthetic_tracks(seed: int) -> tuple[pd.DataFrame, dict[str, float]]:
    """A lane of IDM drivers (`TRUE`, desired speeds drawn by `seed`) behind a scripted leader "lead" that slows,
    stops, starts and cruises, and a lane of free drivers accelerating from 15 m/s, 60 s at SUMO's step: the
    scene's tracks and each driver's desired speed."""
    rng = np.random.default_rng(seed)
    times = np.arange(600) * STEP_S
    lead = np.clip(np.interp(times, [0, 10, 18, 24, 34, 44, 60], [30, 22, 0, 0, 28, 20, 32]), 0, None)
    desired = {f"d{k}": float(rng.uniform(28, 38)) for k in range(8)} | {f"f{k}": float(rng.uniform(28, 38))
                                                                        for k in range(4)}
    rows = []
    position = {"lead": 400.0} | {f"d{k}": 400.0 - 40.0 * (k + 1) for k in range(8)} | {
        f"f{k}": 300.0 * k for k in range(4)}
    speed = {"lead": lead[0]} | {f"d{k}": 25.0 for k in range(8)} | {f"f{k}": 15.0 for k in range(4)}
    for step, time_s in enumerate(times):
        for name in position:
            lane = 1 if name.startswith("f") else 0
            rows.append((name, round(time_s, 9), position[name], -1.6 - 3.2 * (1 - lane), 90.0, speed[name], 0.0,
                         "road", lane, position[name], 4.5, 1.8, "passenger"))
        ahead = "lead"
        new = {"lead": lead[min(step + 1, len(lead) - 1)]}
        for k in range(8):
            name = f"d{k}"
            gap = position[ahead] - 4.5 - position[name]
            new[name] = float(next_speed(TRUE, np.array(speed[name]), np.array(desired[name]), np.array(gap),
                                         np.array(speed[ahead]), STEP_S))
            ahead = name
        for k in range(3, -1, -1):  # f3 ahead of the others
            name, ahead = f"f{k}", f"f{k + 1}"
            gap = position[ahead] - 4.5 - position[name] if k < 3 else np.inf
            new[name] = float(next_speed(TRUE, np.array(speed[name]), np.array(desired[name]), np.array(gap),
                                         np.array(speed.get(ahead, 0.0)), STEP_S))
        for name in position:
            speed[name] = new[name]
            position[name] += speed[name] * STEP_S
    columns = ["vehicle_id", "time_s", "x_m", "y_m", "heading_deg", "speed_mps", "acceleration_mps2", "edge", "lane",
               "lane_position_m", "length_m", "width_m", "vehicle_class"]
    return pd.DataFrame(rows, columns=columns), desired


def test_the_fit_recovers_the_parameters_and_desired_speeds_that_made_a_scene(road):
    tracks, desired = synthetic_tracks(seed=1)
    drivers = sorted(desired)
    split = pd.DataFrame({"vehicle_id": ["lead", *drivers], "split": ["test", *["train"] * len(drivers)]})
    calibration = calibrate(tracks, split, road, STEP_S)
    np.testing.assert_allclose(calibration.parameters.as_array(), TRUE.as_array(), rtol=0.05)
    errors = calibration.errors["train"]
    assert errors["calibrated"].speed_rmse_mps < 0.01 < errors["sumo_defaults"].speed_rmse_mps
    assert calibration.errors["validation"]["calibrated"].windows == 0  # no validation driver here
    windows = windows_of(scene_rows(tracks, road, STEP_S), set(drivers), STEP_S, CalibrationSettings())
    _, speeds = fit(windows, STEP_S, CalibrationSettings())
    np.testing.assert_allclose(speeds, [desired[name] for name in windows.drivers], atol=0.3)
    seats = windows_of(scene_rows(tracks, road, STEP_S), set(drivers), STEP_S, CalibrationSettings(span_s=(5.0, 20.0)))
    assert len(seats) == len(drivers) * 27  # 2 s windows every 0.5 s from 5 s to 18 s into each track
    assert (seats.speed_mps[seats.drivers[seats.driver] == "f0"][0] ==
            tracks[(tracks["vehicle_id"] == "f0") & np.isclose(tracks["time_s"], 5.0)]["speed_mps"]).all()


def test_the_desired_speed_is_read_from_the_lead_in_alone(road):
    """A free driver still accelerating in its 6 s lead-in: its desired speed read from how it accelerates, the same
    whatever it does after the seat's instant; a seat where the track begins reads its first speed; never below the
    typical desired speed given."""
    tracks, desired = synthetic_tracks(seed=2)
    read = lead_in_desired_speed(tracks, road, "f1", 6.0, TRUE, STEP_S)
    assert tracks[(tracks["vehicle_id"] == "f1") & (tracks["time_s"] < 6.0)]["speed_mps"].max() < desired["f1"] - 3
    assert read == pytest.approx(desired["f1"], abs=0.3)
    later = (tracks["vehicle_id"] == "f1") & (tracks["time_s"] >= 6.0)
    changed = tracks.assign(speed_mps=np.where(later, 5.0, tracks["speed_mps"]))
    assert lead_in_desired_speed(changed, road, "f1", 6.0, TRUE, STEP_S) == read
    assert lead_in_desired_speed(tracks, road, "f1", 0.0, TRUE, STEP_S) == pytest.approx(15.0)
    assert lead_in_desired_speed(tracks, road, "f1", 6.0, TRUE, STEP_S, typical_mps=read + 5.0) == read + 5.0
    assert lead_in_desired_speed(tracks, road, "f1", 6.0, TRUE, STEP_S, typical_mps=read - 5.0) == read
    with pytest.raises(ValueError, match="no vehicle 'nobody'"):
        lead_in_desired_speed(tracks, road, "nobody", 6.0, TRUE, STEP_S)
