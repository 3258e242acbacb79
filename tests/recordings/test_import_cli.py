"""`sumo-rail import-recording`: the scene folder it writes, what it says, and bad input in one sentence with nothing
written (exit 2 before any work, 1 for what is found in the data)."""

from __future__ import annotations

import json

import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from recording_files import fcd_vehicle, highd_vehicle, lane_y, ngsim_vehicle, write_fcd, write_highd, write_ngsim
from sumo_rail_cli.main import cli

from sumo_rail.datasets import file_sha256, read_metadata
from sumo_rail.recordings.scene import TRACK_SCHEMA


def invoke(*args: str):
    return CliRunner().invoke(cli, ["import-recording", *args])


def highd_recording(folder, extra=()):
    rows = [row for vehicle in range(1, 11)
            for row in highd_vehicle(vehicle, range(1 + 20 * vehicle, 60 + 20 * vehicle), 10.0 + 3 * vehicle,
                                     5 + vehicle % 2, upper=False)]
    rows += highd_vehicle(20, range(1, 40), 300.0, 2, upper=True) + list(extra)
    return write_highd(folder, rows + highd_vehicle(30, range(1, 8), 200.0, 6, upper=False))


def test_a_highd_recording_becomes_a_scene_folder(tmp_path):
    recording = highd_recording(tmp_path)
    result = invoke("--format", "highd", str(recording), "--out", str(tmp_path / "scene"), "--split-seed", "3")
    assert result.exit_code == 0, result.output
    assert "kept 10 tracks, dropped 1 (1 too short for one decision)" in result.output
    assert "the upper driving direction (1 vehicles) is left out" in result.output
    assert sorted(path.name for path in (tmp_path / "scene").iterdir()) == ["road.net.xml", "scene.json",
                                                                          "split.parquet", "tracks.parquet"]
    tracks = pq.read_table(tmp_path / "scene" / "tracks.parquet")
    assert tracks.schema.remove_metadata() == TRACK_SCHEMA and tracks.num_rows == 10 * 59
    scene = json.loads((tmp_path / "scene" / "scene.json").read_text())
    assert scene["dropped"] == {"30": "too short for one decision"} and scene["lanes"] == 2
    assert scene["settings"]["direction"] == "lower" and not {"site", "period", "network", "vtypes"} & set(
        scene["settings"])  # only the settings highD reads
    read = [recording, tmp_path / "01_tracksMeta.csv", tmp_path / "01_recordingMeta.csv"]  # every file the reader read
    assert scene["sources"] == {str(path.resolve()): file_sha256(path) for path in read}
    assert scene["sources"][str(recording.resolve())] == read_metadata(tmp_path / "scene" / "tracks.parquet")[
        "scene"]["sources"][str(recording.resolve())]
    split = pq.read_table(tmp_path / "scene" / "split.parquet").to_pydict()
    assert sorted(split["split"]) == ["test"] * 2 + ["train"] * 7 + ["validation"]
    again = invoke("--format", "highd", str(recording), "--out", str(tmp_path / "again"), "--split-seed", "3")
    assert again.exit_code == 0
    for name in ("road.net.xml", "scene.json", "split.parquet", "tracks.parquet"):
        assert (tmp_path / "scene" / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name


def test_holding_out_by_time_tests_the_vehicles_that_enter_later(tmp_path):
    recording = highd_recording(tmp_path)
    result = invoke("--format", "highd", str(recording), "--out", str(tmp_path / "scene"), "--hold-out-after", "6",
                    "--validation-share", "0")
    assert result.exit_code == 0, result.output
    split = pq.read_table(tmp_path / "scene" / "split.parquet").to_pydict()
    held = {vehicle for vehicle, part in zip(split["vehicle_id"], split["split"], strict=True) if part == "test"}
    assert held == {"8", "9", "10"}  # vehicle k enters at frame 1 + 20 k, at 20 k / 25 s: 7 at 5.6 s, 8 at 6.4 s


def test_an_ngsim_recording_keeps_its_ramp_vehicles_and_says_so(tmp_path):
    rows = ngsim_vehicle(1, range(1, 40), 0.0, 2) + ngsim_vehicle(2, range(1, 40), 30.0, 8)
    path = write_ngsim(tmp_path / "trajectories.csv", rows)
    result = invoke("--format", "ngsim", str(path), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0, result.output
    assert "kept 2 tracks, dropped 0" in result.output
    assert "lanes 1 to 6 along the whole section, a ramp lane right of them; every track kept" in result.output


def bad_value(column, value, vehicle=3):
    def change(row):
        if row["id"] == vehicle and row["frame"] == 70:
            row[column] = value
        return row
    return change


BREAKAGES = {
    "nan": (lambda rows: [bad_value("xVelocity", "nan")(row) for row in rows],
            "column xVelocity of vehicle 3 at frame 70 is missing or not a number"),
    "too fast": (lambda rows: [bad_value("xVelocity", 120.0)(row) for row in rows],
                 "vehicle 3 has xVelocity 120.0 m/s at frame 70, outside [0, 100] m/s"),
    "too long": (lambda rows: [bad_value("width", 31.0)(row) for row in rows],
                 "vehicle 3 has width 31.0 m at frame 70, outside (0, 30] m"),
    "gap": (lambda rows: [row for row in rows if not (row["id"] == 3 and row["frame"] == 70)],
            "vehicle 3 has a gap in its frames before frame 71"),
    "lane": (lambda rows: [bad_value("laneId", 9)(row) for row in rows],
             "lane 9 of vehicle 3 at frame 70 is not a lane of the lower direction's markings"),
    "empty": (lambda rows: [], "holds no vehicle; the recording is empty"),
    "blank row": (lambda rows: [*rows[:3], dict.fromkeys(rows[0], float("nan")), *rows[3:]],
                  "in data row 4 (a row without a vehicle id or frame) is missing or not a number"),
}


@pytest.mark.parametrize("breakage", BREAKAGES)
def test_broken_data_is_one_sentence_exit_1_and_nothing_written(tmp_path, breakage):
    change, message = BREAKAGES[breakage]
    rows = [row for vehicle in range(1, 6)
            for row in highd_vehicle(vehicle, range(1 + 20 * vehicle, 60 + 20 * vehicle), 10.0, 5, upper=False)]
    recording = write_highd(tmp_path, change(rows))
    if breakage == "empty":
        recording.write_text(recording.read_text().splitlines()[0] + "\n")
    result = invoke("--format", "highd", str(recording), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 1 and message in result.output and "Traceback" not in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "scene").exists()


def test_a_reused_highd_id_is_refused(tmp_path):
    recording = highd_recording(tmp_path)
    meta = recording.parent / "01_tracksMeta.csv"
    lines = meta.read_text().splitlines()
    meta.write_text("\n".join([*lines, lines[1]]) + "\n")
    result = invoke("--format", "highd", str(recording), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 1 and "vehicle id 1 is used twice; highD ids are unique" in result.output


def test_fcd_edges_not_in_the_network_exit_1(tmp_path):
    from sumo_rail.recordings.road import build_road

    build_road([3.2, 3.2], 300.0, tmp_path / "net.net.xml")
    steps = "".join(f'<timestep time="{t}.00"><vehicle id="v" x="{t}" y="-1.6" angle="90" type="car" speed="20" '
                    f'pos="{t}" lane="ramp_0"/></timestep>' for t in range(5))
    (tmp_path / "fcd.xml").write_text(f"<fcd-export>{steps}</fcd-export>")
    result = invoke("--format", "fcd", str(tmp_path / "fcd.xml"), "--network", str(tmp_path / "net.net.xml"),
                    "--out", str(tmp_path / "scene"))
    assert result.exit_code == 1 and "is on lane 'ramp_0', which the network" in result.output, result.output
    assert not (tmp_path / "scene").exists()


@pytest.mark.parametrize("case", ["renamed column", "other format", "missing meta", "fcd without network",
                                  "direction for ngsim", "bad section", "existing scene"])
def test_usage_errors_exit_2_before_any_work(tmp_path, case):
    recording = highd_recording(tmp_path)
    ngsim_file = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 20), 0.0, 2))
    args = {"renamed column": ("--format", "highd", str(recording)),
            "other format": ("--format", "ngsim", str(recording)),
            "missing meta": ("--format", "highd", str(recording)),
            "fcd without network": ("--format", "fcd", str(ngsim_file)),
            "direction for ngsim": ("--format", "ngsim", str(ngsim_file), "--direction", "upper"),
            "bad section": ("--format", "highd", str(recording), "--section", "400:100"),
            "existing scene": ("--format", "highd", str(recording))}[case]
    expected = {"renamed column": "lacks the column 'laneId'", "other format": "is not a NGSIM trajectory file",
                "missing meta": "01_tracksMeta.csv does not exist", "fcd without network": "--network is needed",
                "direction for ngsim": "--direction applies to --format highd only",
                "bad section": "needs START < END", "existing scene": "already holds a scene"}[case]
    if case == "renamed column":
        recording.write_text(recording.read_text().replace("laneId", "lane_id", 1))
    if case == "missing meta":
        (tmp_path / "01_tracksMeta.csv").unlink()
    if case == "existing scene":
        (tmp_path / "scene").mkdir()
        (tmp_path / "scene" / "scene.json").write_text("{}")
    result = invoke(*args, "--out", str(tmp_path / "scene"))
    assert result.exit_code == 2 and expected in result.output and "Traceback" not in result.output, result.output
    assert case == "existing scene" or not (tmp_path / "scene").exists()


def test_fcd_keeps_the_users_network_and_vehicles_and_a_section_select_rows(tmp_path):
    from sumo_rail.recordings.road import build_road

    build_road([3.2, 3.2], 300.0, tmp_path / "net.net.xml")
    steps = "".join(f'<timestep time="{t / 10:.2f}">' + "".join(
        f'<vehicle id="{vehicle}" x="{10 + 2 * t + 50 * k:.2f}" y="-1.60" angle="90.00" type="car" speed="20.00" '
        f'pos="{10 + 2 * t + 50 * k:.2f}" lane="road_1"/>' for k, vehicle in enumerate(("a", "b", "c")))
        + "</timestep>" for t in range(60))
    (tmp_path / "fcd.xml").write_text(f"<fcd-export>{steps}</fcd-export>")
    result = invoke("--format", "fcd", str(tmp_path / "fcd.xml"), "--network", str(tmp_path / "net.net.xml"),
                    "--vehicles", "a,b", "--section", "0:100", "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0, result.output
    assert sorted(path.name for path in (tmp_path / "scene").iterdir()) == ["scene.json", "split.parquet",
                                                                          "tracks.parquet"]
    scene = json.loads((tmp_path / "scene" / "scene.json").read_text())
    assert scene["network"] == str((tmp_path / "net.net.xml").resolve()) and scene["frame_rate_hz"] == 10.0
    assert not {"direction", "site", "period"} & set(scene["settings"])  # highD's and NGSIM's, which FCD does not read
    assert scene["settings"]["network"] == str(tmp_path / "net.net.xml") and scene["settings"]["vehicles"] == ["a", "b"]
    tracks = pq.read_table(tmp_path / "scene" / "tracks.parquet").to_pandas()
    assert sorted(tracks["vehicle_id"].unique()) == ["a", "b"] and tracks["x_m"].max() <= 100.0
    assert tracks["lane"].unique().tolist() == [1] and tracks["edge"].unique().tolist() == ["road"]


def test_fcd_vehicles_take_their_class_and_size_and_those_that_are_no_motor_vehicles_are_left_out(tmp_path):
    """Was every type without a size a 5 m x 1.8 m car, a bicycle too, which a seat could then take."""
    from sumo_rail.recordings.road import build_road

    build_road([3.2, 3.2], 300.0, tmp_path / "net.net.xml")
    (tmp_path / "types.add.xml").write_text('<additional><vType id="lorry" vClass="truck"/>'
                                            '<vType id="bike" vClass="bicycle" length="1.8"/></additional>')
    types = {"car": "car", "lorry": "lorry", "sumo_bike": "DEFAULT_BIKETYPE", "bike": "bike"}
    rows = [dict(row, type=kind) for k, (vehicle, kind) in enumerate(types.items())
            for row in fcd_vehicle(vehicle, range(30), 20.0 + 25 * k, lane_y(2, 0), "road_0")]
    result = invoke("--format", "fcd", str(write_fcd(tmp_path / "fcd.xml", rows)), "--network",
                    str(tmp_path / "net.net.xml"), "--vtypes", str(tmp_path / "types.add.xml"), "--out",
                    str(tmp_path / "scene"))
    assert result.exit_code == 0, result.output
    assert "2 vehicles that are not motor vehicles (2 bicycle; the first " in result.output
    tracks = pq.read_table(tmp_path / "scene" / "tracks.parquet").to_pandas().drop_duplicates("vehicle_id")
    sizes = {row.vehicle_id: (row.vehicle_class, round(row.length_m, 2), round(row.width_m, 2))
             for row in tracks.itertuples()}
    assert sizes == {"car": ("passenger", 4.5, 1.8), "lorry": ("truck", 7.1, 2.4)}  # SUMO's truck without a size
    alone = [row for row in rows if row["type"] == "DEFAULT_BIKETYPE"]
    result = invoke("--format", "fcd", str(write_fcd(tmp_path / "bikes.xml", alone)), "--network",
                    str(tmp_path / "net.net.xml"), "--out", str(tmp_path / "bikes"))
    assert result.exit_code == 1 and "holds no motor vehicle: 1 vehicles" in result.output, result.output
    assert "Traceback" not in result.output and not (tmp_path / "bikes").exists()


def test_a_vehicle_twice_in_one_frame_is_refused(tmp_path):
    rows = ngsim_vehicle(4, range(1, 30), 0.0, 2)  # and frame 6 again, saying otherwise (a word-for-word repeat is
    path = write_ngsim(tmp_path / "t.csv", [*rows, dict(rows[5], Local_Y=rows[5]["Local_Y"] + 2.0)])  # read once)
    result = invoke("--format", "ngsim", str(path), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 1 and "vehicle 4 appears twice in frame 6" in result.output, result.output
