"""Who drives the reactive vehicles of a recorded scene: each its recorded vType where the recording names one and
came with its definition, else SUMO's IDM calibrated on the scene's train split; said in evaluate-scene's output."""

from __future__ import annotations

import json
import shutil

import pytest
from click.testing import CliRunner
from recording_files import SCENE_SPEED
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_drivers import REACTIVE_IDM_TYPE, reactive_types
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.sumo_drivers import DRIVER_TYPES
from sumo_rail.sim.actions import Action
from sumo_rail.sim.replay import DEFAULT_TYPE
from sumo_rail.sim.simulation import EGO_ID

CONFIG = Config.from_dict({"observation": {"lane_block": 1}, "env": {"max_episode_s": 10.0}})


def types_on_road(scene_folder, types, reactive: bool) -> dict[str, tuple[str, float]]:
    """Each other vehicle's SUMO type and tau [s] one decision into a seat of the scene."""
    env = SceneEnv(CONFIG, scene_folder, reactive=reactive, types=types)
    try:
        spans = env.scene.tracks.groupby("vehicle_id")["time_s"].agg(["min", "max"])
        vehicle = str((spans["max"] - spans["min"]).idxmax())
        env.reset(seed=0, options={"vehicle": vehicle, "start_s": float(spans.loc[vehicle, "min"]) + 2.0})
        env.step(int(Action.KEEP))
        api = env.simulation._api.vehicle
        # a resized vehicle drives its own copy of its type, "TYPE@VEHICLE"
        return {other: (api.getTypeID(other).split("@")[0], api.getTau(other)) for other in api.getIDList()
                if other != EGO_ID}
    finally:
        env.close()


def test_sumos_drivers_drive_their_recorded_types_when_reactive(drivers_scene):
    """record-sumo-drivers keeps each vehicle's type and the types' definitions: the reactive vehicles drive them
    (tau included); replayed ones stay SUMO's default type (SUMO does not drive them)."""
    scene = read_scene(drivers_scene)
    assert set(scene.split["vehicle_id"]) <= set(scene.meta.vehicle_types)
    found = reactive_types(scene, 0.1)
    assert (found.recorded, found.calibrated, found.calibration, found.note) == (len(scene.split), 0, None, "")
    reactive = types_on_road(drivers_scene, found.types, reactive=True)
    assert reactive and all(type_id == scene.meta.vehicle_types[other] for other, (type_id, _) in reactive.items())
    assert all(tau == pytest.approx(float(DRIVER_TYPES[type_id]["tau"])) for type_id, tau in reactive.values())
    replayed = types_on_road(drivers_scene, found.types, reactive=False)
    assert {type_id for type_id, _ in replayed.values()} == {DEFAULT_TYPE}


@pytest.fixture(scope="module")
def untyped_scene(drivers_scene, tmp_path_factory):
    """The drivers scene whose recording names its vehicles' types but came without their definitions."""
    folder = tmp_path_factory.mktemp("untyped") / "scene"
    shutil.copytree(drivers_scene, folder)
    meta = json.loads((folder / "scene.json").read_text())
    (folder / "scene.json").write_text(json.dumps({**meta, "vtypes": {}}))
    return folder


def test_without_the_types_definitions_the_idm_calibrated_on_the_train_split_drives_and_it_is_said(untyped_scene):
    scene = read_scene(untyped_scene)
    found = reactive_types(scene, 0.1)
    assert (found.recorded, found.calibrated) == (0, len(scene.split)) and found.calibration is not None
    assert "without their definitions" in found.note and "--vtypes" in found.note
    assert "SUMO's IDM calibrated on the train split" in found.describe()
    reactive = types_on_road(untyped_scene, found.types, reactive=True)
    assert reactive and {type_id for type_id, _ in reactive.values()} == {REACTIVE_IDM_TYPE}
    assert [tau for _, tau in reactive.values()] == pytest.approx([found.calibration.parameters.tau_s] * len(reactive))


def test_evaluate_scene_says_who_drives_the_reactive_vehicles_and_records_it(drivers_scene, tmp_path):
    out = tmp_path / "seats.parquet"
    result = CliRunner().invoke(cli, ["evaluate-scene", str(drivers_scene), "--policy", "keep", "--seats", "1",
                                      "--horizon-s", "5", "--lead-s", "2", "--mode", "reactive", "--out", str(out),
                                      *SCENE_SPEED, "--set", "scenario.lanes=3"])
    assert result.exit_code == 0, result.output
    vehicles = len(read_scene(drivers_scene).split)
    assert f"{drivers_scene}, reactive vehicles: {vehicles} driven by their recorded vType, 0 by" in result.output
    recorded = read_metadata(out)["reactive_drivers"][str(drivers_scene)]
    assert recorded["recorded_vtype"] == vehicles and set(recorded["vtypes"]) == set(DRIVER_TYPES)
