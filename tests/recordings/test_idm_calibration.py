"""The IDM calibrated on a recorded scene: on SUMO's own IDM drivers it finds their parameters, and as
`sumo-idm-calibrated` it drives the seat with them and with the desired speed of the seated driver's lead-in."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import SCENE_SPEED
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.evaluation.scene_evaluation import CALIBRATED_IDM, calibrated_idm_driver, evaluate_seats
from sumo_rail.recordings import sumo_drivers
from sumo_rail.recordings.idm import SUMO_DEFAULTS, IdmParameters
from sumo_rail.recordings.idm_calibration import CalibrationSettings, calibrate, fit, lead_in_desired_speed, simulated
from sumo_rail.recordings.idm_windows import Windows
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_drivers import SEAT_IDM_TYPE, reactive_types, seat_calibration
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.seats import choose_seats
from sumo_rail.runners.backends import SerialBackend
from sumo_rail.runners.rollout import SumoIdmDriver
from sumo_rail.sim.network import netconvert, sumo_binary
from sumo_rail.sim.simulation import EGO_ID

CONFIG = Config.from_dict({"observation": {"lane_block": 1}, "env": {"max_episode_s": 10.0}})
IDM_DRIVER = "car_idm_cooperative"


@pytest.fixture(scope="module")
def idm_scene(tmp_path_factory):
    """60 s of SUMO's drivers on 1 km of three lanes, every one of them `IDM_DRIVER` (the drivers_scene fixture's
    recording does not say which of its drivers are IDM's)."""
    folder = tmp_path_factory.mktemp("idm") / "scene"
    only = {IDM_DRIVER: {**sumo_drivers.DRIVER_TYPES[IDM_DRIVER], "probability": "1"}}
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sumo_drivers, "DRIVER_TYPES", only)
        sumo_drivers.record_sumo_drivers(
            sumo_drivers.SumoDriversSettings(out=folder, seed=4, duration_s=60.0),
            Config.from_dict({"scenario": {"length_m": 1000.0, "lanes": 3, "flow_veh_per_h": 3000.0,
                                           "warmup_s": 30.0}}))
    return folder


def test_the_calibration_finds_sumos_idm_drivers_parameters(idm_scene):
    """accel, decel, tau and delta within 5% of the type's; minGap, the standstill gap, within 1 m (motorway traffic
    barely shows it); SUMO's defaults (tau 1.0 s) fit the validation drivers worse."""
    scene = read_scene(idm_scene)
    calibration = calibrate(scene.tracks, scene.split, scene.road, 0.1)
    drivers = sumo_drivers.DRIVER_TYPES[IDM_DRIVER]
    found = calibration.parameters
    truth = IdmParameters(float(drivers["accel"]), float(drivers["decel"]), float(drivers["tau"]),
                          float(drivers["minGap"]), 4.0)  # SUMO's default delta
    np.testing.assert_allclose([found.accel_mps2, found.decel_mps2, found.tau_s, found.delta],
                               [truth.accel_mps2, truth.decel_mps2, truth.tau_s, truth.delta], rtol=0.05)
    assert found.min_gap_m == pytest.approx(truth.min_gap_m, abs=1.0)
    validation = calibration.errors["validation"]
    assert validation["calibrated"].windows > 50
    assert validation["calibrated"].speed_median_mps < validation["sumo_defaults"].speed_median_mps / 3
    assert calibration.as_dict()["parameters"]["tau_s"] == found.tau_s


FCD_IDM = IdmParameters(2.0, 3.0, 1.2, 2.5, 4.0)
"""The IDM vType of `fcd_idm_scene`'s cars."""


@pytest.fixture(scope="module")
def fcd_idm_scene(tmp_path_factory):
    """150 s of SUMO's IDM cars (`FCD_IDM`) on a bent road of two edges built by netconvert, recorded as FCD at SUMO's
    default step (1 s: frames ten of the project's 0.1 s steps apart), imported without --vtypes."""
    folder = tmp_path_factory.mktemp("fcd_idm")
    (folder / "road.nod.xml").write_text('<nodes><node id="a" x="0" y="0"/><node id="b" x="600" y="0"/>'
                                         '<node id="c" x="1100" y="150"/></nodes>')
    (folder / "road.edg.xml").write_text('<edges><edge id="ab" from="a" to="b" numLanes="2" speed="30"/>'
                                         '<edge id="bc" from="b" to="c" numLanes="2" speed="30"/></edges>')
    netconvert({"nodes": folder / "road.nod.xml", "edges": folder / "road.edg.xml"}, folder / "road.net.xml")
    p = FCD_IDM
    (folder / "cars.rou.xml").write_text(
        f'<routes><vType id="idm_car" carFollowModel="IDM" accel="{p.accel_mps2}" decel="{p.decel_mps2}" '
        f'tau="{p.tau_s}" minGap="{p.min_gap_m}" delta="{p.delta}"/><flow id="f" type="idm_car" from="ab" to="bc" '
        'begin="0" end="150" vehsPerHour="2400" departLane="random" departSpeed="random"/></routes>')
    subprocess.run([sumo_binary("sumo"), "-n", str(folder / "road.net.xml"), "-r", str(folder / "cars.rou.xml"),
                    "--end", "150", "--seed", "1", "--fcd-output", str(folder / "fcd.xml"), "--no-step-log",
                    "--no-warnings"], check=True, capture_output=True)
    result = CliRunner().invoke(cli, ["import-recording", "--format", "fcd", str(folder / "fcd.xml"), "--network",
                                      str(folder / "road.net.xml"), "--out", str(folder / "scene")])
    assert result.exit_code == 0, result.output
    return folder / "scene"


def test_both_calibrations_find_sumos_idm_in_fcd_at_sumos_default_step(fcd_idm_scene):
    """The reactive vehicles' IDM (every train window) and the seat's (the train seats' span) recover the vType's
    accel and delta within 5% from 1 s frames resampled on the 0.1 s step, and fit the validation windows better
    than SUMO's defaults (1 s frames show little of tau, minGap and decel, which trade off). They found no window: the
    frames, on multiples of the step, were taken as one a step, so no 2 s window had its consecutive steps."""
    scene = read_scene(fcd_idm_scene)
    reactive = reactive_types(scene, 0.1)
    assert reactive.calibrated == len(scene.split) and reactive.calibration is not None, reactive.note
    for found in (reactive.calibration, seat_calibration(scene, 0.1, 5.0, 15.0)):
        fitted = found.parameters
        np.testing.assert_allclose([fitted.accel_mps2, fitted.delta], [FCD_IDM.accel_mps2, FCD_IDM.delta], rtol=0.05)
        validation = found.errors["validation"]
        assert validation["calibrated"].speed_median_mps < validation["sumo_defaults"].speed_median_mps / 3


def test_drivers_without_a_leader_calibrate_what_they_show_and_leave_the_rest():
    """Free-road windows (sparse traffic: no train driver ever has a leader) say nothing of decel, tau and minGap: the
    fit keeps SUMO's values of those and finds accel and the desired speeds (it stopped at a singular matrix)."""
    speeds = np.linspace(20.0, 28.0, 6)
    free = Windows(np.array(["a", "b"]), np.array([20.0, 24.0]), np.repeat([0, 1], 3), np.zeros(6), speeds,
                   np.full(6, np.inf), np.zeros((6, 20)), np.zeros((6, 20)), np.zeros((6, 20)), np.zeros(6))
    truth = dataclasses.replace(SUMO_DEFAULTS, accel_mps2=1.5)
    recorded = simulated(truth, free, np.array([30.0, 32.0]), 0.1)
    free = dataclasses.replace(free, recorded_mps=recorded, recorded_travel_m=recorded.sum(axis=1) * 0.1)
    found, desired = fit(free, 0.1, CalibrationSettings())
    assert found.accel_mps2 == pytest.approx(1.5, rel=1e-3) and desired == pytest.approx([30.0, 32.0], abs=0.05)
    assert (found.decel_mps2, found.tau_s, found.min_gap_m) == pytest.approx(
        (SUMO_DEFAULTS.decel_mps2, SUMO_DEFAULTS.tau_s, SUMO_DEFAULTS.min_gap_m), rel=1e-6)


def test_the_calibrated_idm_takes_the_seat(drivers_scene):
    """The seat's SUMO type carries the calibrated parameters and the desired speed read from the lead-in."""
    scene = read_scene(drivers_scene)
    driver, calibrations = calibrated_idm_driver([scene], CONFIG.scenario.step_length_s, 2.0, 10.0)
    found = calibrations[str(drivers_scene)]
    parameters = found.parameters
    assert driver.name == CALIBRATED_IDM and driver.idm == ((str(drivers_scene), parameters, found.desired_mps),)
    assert parameters != SUMO_DEFAULTS and found.settings.span_s == (2.0, 12.0)
    seat = choose_seats(scene, "test", 10.0, 2.0, 1, 0)[0]
    desired = lead_in_desired_speed(scene.tracks, scene.road, seat.vehicle, seat.start_s, parameters, 0.1,
                                    typical_mps=found.desired_mps)
    controller, types = driver.seat_controller(scene, seat, 0.1)
    assert controller.type_id == SEAT_IDM_TYPE and controller.desired_mps == desired
    env = SceneEnv(CONFIG, scene, types=types)
    try:
        env.reset(seed=0, options={"vehicle": seat.vehicle, "start_s": seat.start_s, "controller": controller})
        vehicle = env.simulation._api.vehicle
        assert vehicle.getTypeID(EGO_ID).split("@")[0] == SEAT_IDM_TYPE
        assert [vehicle.getAccel(EGO_ID), vehicle.getDecel(EGO_ID), vehicle.getTau(EGO_ID),
                vehicle.getMinGap(EGO_ID)] == pytest.approx(parameters.as_array()[:4].tolist())
        assert vehicle.getAllowedSpeed(EGO_ID) == pytest.approx(desired)
    finally:
        env.close()


def test_the_calibrated_idm_drives_recorded_seats(drivers_scene):
    scene = read_scene(drivers_scene)
    calibrated, _ = calibrated_idm_driver([scene], CONFIG.scenario.step_length_s, 2.0, 10.0)
    seats = choose_seats(scene, "test", 10.0, 2.0, 2, 0)
    with SerialBackend() as backend:
        evaluation = evaluate_seats([SumoIdmDriver(), calibrated], ["sumo-idm", CALIBRATED_IDM], CONFIG, seats,
                                    ["non-reactive"], backend, seed=3)
    metrics, tracks = evaluation.metrics, evaluation.decisions
    assert metrics["policy"].tolist() == ["sumo-idm"] * 2 + [CALIBRATED_IDM] * 2
    assert np.isfinite(metrics["position_error_1s_m"]).all() and (metrics["collisions"] == 0).all()
    (_, parameters, typical), = calibrated.idm
    assert metrics["desired_mps"].iloc[:2].isna().all()
    assert metrics["desired_mps"].iloc[2:].tolist() == [
        lead_in_desired_speed(scene.tracks, scene.road, seat.vehicle, seat.start_s, parameters, 0.1,
                              typical_mps=typical) for seat in seats]
    defaults, fitted = (tracks[tracks["policy"] == name]["speed_mps"].to_numpy()
                        for name in ("sumo-idm", CALIBRATED_IDM))
    assert len(defaults) == len(fitted) and not np.allclose(defaults, fitted)


def invoke(*args: str):
    """sumo-rail evaluate-scene ARGS with the scene road's speed settings and the drivers scene's lanes."""
    return CliRunner().invoke(cli, ["evaluate-scene", *args, *SCENE_SPEED, "--set", "scenario.lanes=3"])


def test_evaluate_scene_says_the_calibration_and_records_it(drivers_scene, tmp_path):
    out = tmp_path / "seats.parquet"
    result = invoke(str(drivers_scene), "--policy", CALIBRATED_IDM, "--seats", "1", "--horizon-s", "10", "--lead-s",
                    "2", "--mode", "non-reactive", "--out", str(out))
    assert result.exit_code == 0, result.output
    assert f"{drivers_scene}, {CALIBRATED_IDM}: IDM calibrated on " in result.output
    assert "sumo_defaults" in result.output
    recorded = read_metadata(out)["idm_calibration"][str(drivers_scene)]
    assert set(recorded["parameters"]) == {"accel_mps2", "decel_mps2", "tau_s", "min_gap_m", "delta"}
    assert recorded["errors"]["validation"]["calibrated"]["windows"] > 0
    assert np.isfinite(pd.read_parquet(out)["desired_mps"]).all()


def test_a_scene_without_train_drivers_cannot_be_calibrated(drivers_scene, tmp_path):
    scene = tmp_path / "untrained"
    shutil.copytree(drivers_scene, scene)
    split = pd.read_parquet(scene / "split.parquet")
    split.assign(split=np.where(split["split"] == "train", "validation", split["split"])).to_parquet(
        scene / "split.parquet", index=False)
    out = tmp_path / "seats.parquet"
    result = invoke(str(scene), "--policy", CALIBRATED_IDM, "--horizon-s", "10", "--lead-s", "2", "--out", str(out))
    assert result.exit_code == 2, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and f"cannot calibrate SUMO's IDM on the train split of the scene {scene}" in errors[0]
    assert "Traceback" not in result.output and not out.exists()
