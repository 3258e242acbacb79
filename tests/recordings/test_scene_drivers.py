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
from sumo_rail.recordings.scene_drivers import REACTIVE_IDM_TRUCK_TYPE, REACTIVE_IDM_TYPE, reactive_types, sumo_type_ids
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
    trucks = set(scene.tracks.loc[scene.tracks["vehicle_class"] == "truck", "vehicle_id"])
    assert reactive and all(type_id == (REACTIVE_IDM_TRUCK_TYPE if other in trucks else REACTIVE_IDM_TYPE)
                            for other, (type_id, _) in reactive.items())
    assert [tau for _, tau in reactive.values()] == pytest.approx([found.calibration.parameters.tau_s] * len(reactive))


def test_evaluate_scene_says_who_drives_the_reactive_vehicles_and_records_it(drivers_scene, tmp_path):
    out = tmp_path / "seats.parquet"
    result = CliRunner().invoke(cli, ["evaluate-scene", str(drivers_scene), "--policy", "keep", "--seats", "1",
                                      "--horizon-s", "5", "--lead-s", "2", "--mode", "reactive", "--out", str(out),
                                      *SCENE_SPEED, "--set", "scenario.lanes=3"])
    assert result.exit_code == 0, result.output
    vehicles = len(read_scene(drivers_scene).split)
    assert f"{drivers_scene}, reactive vehicles: {vehicles} driven by their recorded vType\n" in result.output
    recorded = read_metadata(out)["reactive_drivers"][str(drivers_scene)]
    assert recorded["recorded_vtype"] == vehicles and set(recorded["vtypes"]) == set(DRIVER_TYPES)


def fcd_scene_files(folder):
    """An FCD recording on a built 300 m road of two lanes: "a" and "b" of type car_calm, "t" of type lorry."""
    from recording_files import fcd_vehicle

    from sumo_rail.recordings.road import build_road

    build_road([3.2, 3.2], 300.0, folder / "net.net.xml")
    rows = [row for k, vehicle in enumerate("abt") for row in fcd_vehicle(vehicle, range(60), 10.0 + 50 * k, -1.6,
                                                                           "road_1")]
    lines = "".join(f'<timestep time="{t / 10:.2f}">' + "".join(
        f'<vehicle id="{row["id"]}" x="{row["x"]:.2f}" y="-1.60" angle="90.00" '
        f'type="{"lorry" if row["id"] == "t" else "car_calm"}" speed="20.00" pos="{row["x"]:.2f}" lane="road_1"/>'
        for row in rows if round(row["time"] * 10) == t) + "</timestep>" for t in range(60))
    (folder / "fcd.xml").write_text(f"<fcd-export>{lines}</fcd-export>")
    (folder / "types.rou.xml").write_text('<routes><vType id="car_calm" carFollowModel="IDM" tau="1.7"/>'
                                          '<vType id="other" tau="1.1"/></routes>')
    return ["--format", "fcd", str(folder / "fcd.xml"), "--network", str(folder / "net.net.xml")]

def imported(tmp_path, files) -> None:
    """import-recording of the FCD recording `files` with tmp_path/types.rou.xml as --vtypes into tmp_path/scene."""
    result = CliRunner().invoke(cli, ["import-recording", *files, "--vtypes", str(tmp_path / "types.rou.xml"),
                                      "--out", str(tmp_path / "scene")])
    assert result.exit_code == 0, result.output



def test_an_fcd_scene_keeps_each_vehicles_vtype_and_the_definitions_given(tmp_path):
    """import-recording --vtypes keeps the definitions of the types the recording names; a type it does not define
    (lorry) is said by the reactive mode's choice, which the IDM calibrated on the train split then drives (here,
    with no leader to fit its gap terms, SUMO's decel, tau and minGap with what the tracks show)."""
    result = CliRunner().invoke(cli, ["import-recording", *fcd_scene_files(tmp_path), "--vtypes",
                                      str(tmp_path / "types.rou.xml"), "--out", str(tmp_path / "scene")])
    assert result.exit_code == 0, result.output
    scene = read_scene(tmp_path / "scene")
    assert scene.meta.vehicle_types == {"a": "car_calm", "b": "car_calm", "t": "lorry"}
    assert scene.meta.vtypes == {"car_calm": {"carFollowModel": "IDM", "tau": "1.7"}}
    assert str((tmp_path / "types.rou.xml").resolve()) in scene.meta.sources
    found = reactive_types(scene, 0.1)
    assert found.recorded == 2 and found.calibrated == 1 and "lorry" in found.note
    assert found.types.of_vehicle == {"a": "car_calm", "b": "car_calm", "t": REACTIVE_IDM_TYPE}


@pytest.mark.parametrize("case", ["not fcd", "no vtype", "not xml", "too long"])
def test_vtypes_refused_in_one_sentence(tmp_path, case):
    files = fcd_scene_files(tmp_path)
    (tmp_path / "empty.xml").write_text("<routes/>")
    (tmp_path / "broken.xml").write_text("<routes><vType")
    (tmp_path / "long.xml").write_text('<routes><vType id="car_calm" length="40"/></routes>')
    given = {"not fcd": tmp_path / "types.rou.xml", "no vtype": tmp_path / "empty.xml",
             "not xml": tmp_path / "broken.xml", "too long": tmp_path / "long.xml"}[case]
    if case == "not fcd":
        files = ["--format", "ngsim", str(tmp_path / "fcd.xml")]
    result = CliRunner().invoke(cli, ["import-recording", *files, "--vtypes", str(given), "--out",
                                      str(tmp_path / "scene")])
    said = {"not fcd": "--vtypes applies to --format fcd only", "no vtype": f"--vtypes {given} defines no vType",
            "not xml": f"--vtypes {given} is not a readable route or additional file",
            "too long": f"--vtypes {given}: vType car_calm has length 40 m, longer than 30 m"}[case]
    assert result.exit_code == 2 and said in result.output and "Traceback" not in result.output, result.output
    assert not (tmp_path / "scene").exists()


def test_a_recorded_vtype_named_as_a_built_in_type_drives_the_reactive_vehicles(tmp_path):
    """An FCD recording whose vType is named "car" (a type of the road's own traffic, whose flows a scene leaves out):
    the recording's definition replaces it, and the reactive vehicles drive it (SUMO refused two types "car")."""
    files = fcd_scene_files(tmp_path)
    for name in ("fcd.xml", "types.rou.xml"):
        (tmp_path / name).write_text((tmp_path / name).read_text().replace("car_calm", "car"))
    imported(tmp_path, files)
    found = reactive_types(read_scene(tmp_path / "scene"), 0.1)
    assert found.types.of_vehicle == {"a": "car", "b": "car", "t": REACTIVE_IDM_TYPE}
    reactive = types_on_road(tmp_path / "scene", found.types, reactive=True)
    cars = {other: drove for other, drove in reactive.items() if other in "ab"}
    assert cars and all(drove == ("car", pytest.approx(1.7)) for drove in cars.values()), reactive


def test_the_vtypes_file_sizes_and_classes_the_fcd_vehicles_of_its_types(tmp_path):
    """FCD holds no sizes: a vehicle of a type the --vtypes file defines takes its length, width and class (the
    lorry was a 5 m car, for the seats and the replay, though its recorded type drove as a 16.5 m truck)."""
    files = fcd_scene_files(tmp_path)
    (tmp_path / "types.rou.xml").write_text('<routes><vType id="lorry" vClass="truck" length="16.5" width="2.55"/>'
                                            '</routes>')
    imported(tmp_path, files)
    first = read_scene(tmp_path / "scene").tracks.drop_duplicates("vehicle_id").set_index("vehicle_id")
    assert first.loc["t", ["vehicle_class", "length_m", "width_m"]].tolist() == ["truck", 16.5, pytest.approx(2.55)]
    assert first.loc["a", ["vehicle_class", "length_m"]].tolist() == ["passenger", 5.0]  # not defined: as before


@pytest.mark.parametrize(("vtype", "said"), [
    ('<vType id="car_calm" carFollowModel="Wobbly"/>', "vType 'car_calm': Unknown car following model 'Wobbly'"),
    ('<vType id="car_calm" accel="brisk"/>', "vType 'car_calm': Invalid Car-Following-Model Attribute accel"),
    ('<vType id="car_calm" length="-4.5"/>', "vType 'car_calm': length must be greater than 0"),
    ('<vType id="car_calm" acel="2.6"/>', "vType 'car_calm': attribute 'acel' is not declared"),
    ('<vType id="car_calm" accel="nan"/>', "vType 'car_calm' attribute accel is 'nan', not a finite number"),
    ('<vType tau="1.1"/>', "a vType without an id"),
    ('<vType id="car_calm"><laneChanging-LC2013/></vType>', "vType 'car_calm' has a <laneChanging-LC2013> child"),
])
def test_a_vtype_sumo_would_refuse_is_refused_at_import_naming_the_file_type_and_attribute(tmp_path, vtype, said):
    """What SUMO refuses in a --vtypes file (it used to be found by evaluate-scene's reactive mode) or this project
    cannot keep is refused by import-recording before any work: exit 2, one sentence, nothing written."""
    files = fcd_scene_files(tmp_path)
    given = tmp_path / "types.rou.xml"
    given.write_text(f"<routes>{vtype}</routes>")
    result = CliRunner().invoke(cli, ["import-recording", *files, "--vtypes", str(given), "--out",
                                      str(tmp_path / "scene")])
    assert result.exit_code == 2 and f"--vtypes {given}: " in result.output and said in result.output, result.output
    assert "Traceback" not in result.output and result.output.strip().splitlines()[-1].startswith("Error: --vtypes")
    assert not (tmp_path / "scene").exists()


def test_a_vtypes_car_following_child_and_params_are_kept_and_drive_the_reactive_vehicles(tmp_path):
    """A vType's <carFollowing-IDM> child (SUMO's older way of naming the model) and <param> children are kept in the
    scene and written back for SUMO: the reactive vehicles drive the child's tau and their type holds the params."""
    files = fcd_scene_files(tmp_path)
    (tmp_path / "types.rou.xml").write_text('<routes><vType id="car_calm" maxSpeed="40"><carFollowing-IDM tau="1.7" '
                                            'delta="3"/><param key="note" value="calm"/></vType></routes>')
    imported(tmp_path, files)
    scene = read_scene(tmp_path / "scene")
    assert scene.meta.vtypes == {"car_calm": {"maxSpeed": "40", "carFollowModel": "IDM", "tau": "1.7", "delta": "3",
                                              "param:note": "calm"}}
    found = reactive_types(scene, 0.1)
    env = SceneEnv(CONFIG, tmp_path / "scene", reactive=True, types=found.types)
    try:
        env.reset(seed=0, options={"vehicle": "t", "start_s": 1.0})
        env.step(int(Action.KEEP))
        api = env.simulation._api
        cars = [other for other in api.vehicle.getIDList() if other in "ab"]
        assert cars and all(api.vehicle.getTau(car) == pytest.approx(1.7) for car in cars)
        assert api.vehicletype.getParameter("car_calm", "note") == "calm"
    finally:
        env.close()


@pytest.mark.parametrize(("name", "drives_as"), [("car_calm", "car_calm"), ("ego", "ego_recorded"),
                                                 ("scene_idm", "scene_idm_recorded"),
                                                 (REACTIVE_IDM_TYPE, f"{REACTIVE_IDM_TYPE}_recorded"),
                                                 (DEFAULT_TYPE, f"{DEFAULT_TYPE}_recorded")])
def test_a_recorded_vtype_named_as_one_of_the_projects_own_drives_under_another_name(tmp_path, name, drives_as):
    """An FCD recording whose vType is named as a type the scene's simulation defines itself (the ego's, SUMO's driver
    in a seat, the calibrated IDM's, SUMO's default): SUMO refused two types "ego", or the recorded one took over the
    vehicles of the project's (SUMO's default drove every vehicle without a type by the recorded tau). Now it drives
    under another name, said in the note, and a vehicle without a definition drives the calibrated IDM."""
    files = fcd_scene_files(tmp_path)
    for file in ("fcd.xml", "types.rou.xml"):
        (tmp_path / file).write_text((tmp_path / file).read_text().replace("car_calm", name))
    imported(tmp_path, files)
    scene = read_scene(tmp_path / "scene")
    assert scene.meta.vehicle_types["a"] == name  # the scene stays true to the recording
    found = reactive_types(scene, 0.1)
    assert found.types.of_vehicle == {"a": drives_as, "b": drives_as, "t": REACTIVE_IDM_TYPE}
    assert (f"{name} as {drives_as}" in found.note) == (name != drives_as)
    reactive = types_on_road(tmp_path / "scene", found.types, reactive=True)
    assert reactive["b"] == (drives_as, pytest.approx(1.7)) and reactive["t"][0] == REACTIVE_IDM_TYPE


def test_vehicles_recorded_as_sumos_default_type_drive_it_and_are_not_said_to_lack_a_definition(tmp_path):
    """FCD of vehicles without a type names SUMO's own DEFAULT_VEHTYPE, which no route file defines: that is the
    recorded vType, so they drive it (were: the calibrated IDM, with a note asking for --vtypes, which had been given);
    a type the file does not define (lorry) is still said and calibrated."""
    files = fcd_scene_files(tmp_path)
    (tmp_path / "fcd.xml").write_text((tmp_path / "fcd.xml").read_text().replace("car_calm", DEFAULT_TYPE))
    imported(tmp_path, files)
    found = reactive_types(read_scene(tmp_path / "scene"), 0.1)
    assert (found.recorded, found.calibrated) == (2, 1) and found.types.of_vehicle == {"t": REACTIVE_IDM_TYPE}
    assert "lorry" in found.note and DEFAULT_TYPE not in found.note
    reactive = types_on_road(tmp_path / "scene", found.types, reactive=True)
    assert reactive["b"][0] == DEFAULT_TYPE and reactive["t"][0] == REACTIVE_IDM_TYPE


def test_a_renamed_recorded_vtype_takes_a_name_no_other_type_has():
    assert sumo_type_ids({"ego", "ego_recorded", "car"}) == {"ego": "ego_recorded1", "ego_recorded": "ego_recorded",
                                                             "car": "car"}
