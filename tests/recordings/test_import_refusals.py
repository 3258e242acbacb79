"""`sumo-rail import-recording` on what no recording can be: one sentence naming the file, the vehicle or the column,
exit 1, nothing written; and on what the formats allow but the readers once missed (a byte-order mark, gzip), or
refused with a traceback or binary bytes on the terminal."""

from __future__ import annotations

import gzip
import json
import subprocess

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import (
    fcd_vehicle,
    highd_vehicle,
    lane_y,
    ngsim_vehicle,
    write_fcd,
    write_highd,
    write_ngsim,
)
from sumo_rail_cli.main import cli
from sumo_rail_cli.output_lock import lock_path

from sumo_rail.recordings import highd
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import build_road, read_lanes
from sumo_rail.recordings.tracks import RecordingDataError
from sumo_rail.sim.network import netconvert


def invoke(*args: str):
    return CliRunner().invoke(cli, ["import-recording", *args])


def refused(folder, exit_code: int, *args: str) -> str:
    """The one sentence import-recording says when it refuses `args` (exit `exit_code`; click's usage lines above it
    for exit 2), having written nothing."""
    result = invoke(*args, "--out", str(folder / "scene"))
    assert result.exit_code == exit_code and "Traceback" not in result.output, result.output
    said = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(said) == 1 and said[0] == result.output.strip().splitlines()[-1], result.output
    assert not (folder / "scene").exists()
    return said[0]


def changed(rows: list[dict], vehicle: object, frame: int, column: str, value: object) -> list[dict]:
    """`rows` with `column` of `vehicle` at `frame` set to `value` (highD's id / frame, NGSIM's Vehicle_ID /
    Frame_ID)."""
    for row in rows:
        if row.get("id", row.get("Vehicle_ID")) == vehicle and row.get("frame", row.get("Frame_ID")) == frame:
            row[column] = value
    return rows


def lower_rows() -> list[dict]:
    return [row for vehicle in range(1, 4) for row in highd_vehicle(vehicle, range(1, 40), 10.0 + 20 * vehicle, 6,
                                                                    upper=False)]


HIGHD = {
    "lower driven leftwards": (lambda rows: changed(rows, 2, 20, "xVelocity", -30.0), "lower",
                               "vehicle 2 has xVelocity -30 m/s at frame 20, against the lower direction "
                               "(drivingDirection 2), which is driven toward growing x"),
    "upper driven rightwards": (lambda rows: changed(rows + highd_vehicle(7, range(1, 40), 300.0, 2, upper=True), 7,
                                                     5, "xVelocity", 30.0), "upper",
                                "vehicle 7 has xVelocity 30 m/s at frame 5, against the upper direction "
                                "(drivingDirection 1), which is driven toward falling x"),
    "a billion metres": (lambda rows: changed(rows, 3, 9, "x", 1e9), "lower",
                         "column x of vehicle 3 at frame 9 is 1e+09, not a position within 100 km"),
    "an infinite y": (lambda rows: changed(rows, 1, 2, "y", "inf"), "lower",
                      "column y of vehicle 1 at frame 2 is inf, not a position within 100 km"),
}


@pytest.mark.parametrize("case", HIGHD)
def test_highd_rows_no_recording_can_hold_are_refused(tmp_path, case):
    change, direction, message = HIGHD[case]
    recording = write_highd(tmp_path, change(lower_rows()))
    assert message in refused(tmp_path, 1, "--format", "highd", str(recording), "--direction", direction)


@pytest.mark.parametrize("rate", ["0", "-25", "inf"])
def test_a_highd_frame_rate_that_is_not_positive_is_refused(tmp_path, rate):
    recording = write_highd(tmp_path, lower_rows())
    meta = tmp_path / "01_recordingMeta.csv"
    table = pd.read_csv(meta).assign(frameRate=rate)
    table.to_csv(meta, index=False)
    output = refused(tmp_path, 1, "--format", "highd", str(recording))
    assert f"01_recordingMeta.csv: frameRate {rate} is not a positive number of frames per second" in output


def test_a_highd_road_longer_than_100_km_is_refused_naming_the_farthest_vehicle(tmp_path):
    far = highd_vehicle(1, range(1, 40), -60_000.0, 6, upper=False) + highd_vehicle(2, range(1, 40), 60_000.0, 6,
                                                                                    upper=False)
    with pytest.raises(RecordingDataError, match=r"vehicle 2 at frame 39 is 120\d+ m along the road, which would be "
                                                 "longer than 100 km"):
        highd.read([write_highd(tmp_path, far)], ReadOptions(direction="lower"))


NGSIM = {
    "a negative speed": (lambda rows: changed(rows, 2, 10, "v_Vel", -5.0),
                         "vehicle 2 has v_Vel -1.5 m/s at frame 10, outside [0, 100] m/s"),
    "frames running backwards": (lambda rows: [dict(row, Local_Y=1000.0 - row["Local_Y"]) if row["Vehicle_ID"] == 3
                                               else row for row in rows],
                                 "vehicle 3 runs backwards: by frame 2 its Local_Y has fallen 5.0 ft behind"),
    "a billion metres": (lambda rows: changed(rows, 1, 7, "Local_Y", 1e9 / 0.3048),
                         "column Local_Y of vehicle 1 at frame 7 is 3.28084e+09, not a position within 100 km"),
}


@pytest.mark.parametrize("case", NGSIM)
def test_ngsim_rows_no_recording_can_hold_are_refused(tmp_path, case):
    change, message = NGSIM[case]
    rows = [row for vehicle in (1, 2, 3) for row in ngsim_vehicle(vehicle, range(1, 30), 40.0 * vehicle, 2)]
    path = write_ngsim(tmp_path / "t.csv", change(rows))
    assert message in refused(tmp_path, 1, "--format", "ngsim", str(path))


def test_an_ngsim_track_that_jitters_back_less_than_a_metre_is_read(tmp_path):
    rows = ngsim_vehicle(1, range(1, 30), 100.0, 2, speed_ftps=0.0)
    for row, jitter in zip(rows, [0.0, 3.0, 0.5, 2.8] * 8, strict=False):
        row["Local_Y"] += jitter  # up to 3 ft (0.91 m) back and forth: noise, not a drive backwards
    result = invoke("--format", "ngsim", str(write_ngsim(tmp_path / "t.csv", rows)), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0, result.output


def fcd_network(folder, lanes: int = 3):
    build_road([3.2] * lanes, 400.0, folder / "net.net.xml")
    return folder / "net.net.xml"


def fcd_rows(lanes: int = 3) -> list[dict]:
    return fcd_vehicle("a", range(0, 20), 50.0, lane_y(lanes, 0), "road_0") + fcd_vehicle(
        "b", range(0, 20), 80.0, lane_y(lanes, 2), "road_2")


FCD = {
    "a negative speed": (lambda rows: [dict(row, speed=-1.0) if row["id"] == "b" and row["time"] > 0.25 else row
                                       for row in rows],
                         "vehicle b has speed -1.0 m/s at 0.3 s, outside [0, 100] m/s"),
    "positions of 1e15": (lambda rows: [dict(row, x=1e15) if row["id"] == "a" else row for row in rows],
                          "vehicle a at 0 s lies 1e+15 m from the centre of lane road_0 (3.20 m wide)"),
    "a pos beyond the edge": (lambda rows: [dict(row, pos=1e15) if row["id"] == "b" else row for row in rows],
                              "vehicle b at 0 s lies at pos 1e+15 m of lane road_2 (400.0 m long)"),
    "3 lanes' positions on 5": (lambda rows: rows,
                                "vehicle a at 0 s lies 6.4 m from the centre of lane road_0 (3.20 m wide)"),
    "longitude and latitude": (lambda rows: [dict(row, x=8.68, y=49.41) for row in rows],
                               "its x, y all look like longitude and latitude: written with --fcd-output.geo?"),
    "a lane index of the lane count": (lambda rows: [dict(row, lane="road_3") if row["id"] == "b" else row
                                                     for row in rows], "vehicle b at 0 s is on lane 'road_3', which "
                                                                       "the network"),
}


@pytest.mark.parametrize("case", FCD)
def test_fcd_rows_off_the_lanes_they_name_or_driving_backwards_are_refused(tmp_path, case):
    change, message = FCD[case]
    network = fcd_network(tmp_path, 5 if case.startswith("3 lanes") else 3)
    fcd = write_fcd(tmp_path / "fcd.xml", change(fcd_rows()))
    assert message in refused(tmp_path, 1, "--format", "fcd", str(fcd), "--network", str(network))


def test_fcd_on_its_own_network_is_read(tmp_path):
    result = invoke("--format", "fcd", str(write_fcd(tmp_path / "fcd.xml", fcd_rows())), "--network",
                    str(fcd_network(tmp_path)), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0 and "kept 2 tracks" in result.output, result.output


def one_edge_network(folder, to_xy: tuple[float, float]):
    """A network of one 3-lane edge from (0, 0) to `to_xy`, straight, built by netconvert."""
    (folder / "n.nod.xml").write_text(f'<nodes><node id="a" x="0" y="0"/><node id="b" x="{to_xy[0]}" '
                                      f'y="{to_xy[1]}"/></nodes>')
    (folder / "n.edg.xml").write_text('<edges><edge id="road" from="a" to="b" numLanes="3" speed="30"/></edges>')
    netconvert({"nodes": folder / "n.nod.xml", "edges": folder / "n.edg.xml"}, folder / "net.net.xml")
    return folder / "net.net.xml"


@pytest.mark.parametrize("to_xy", [(0.0, 400.0), (-400.0, 0.0)], ids=["north", "west"])
def test_an_fcd_network_whose_edge_does_not_run_along_x_is_imported(tmp_path, to_xy):
    """Scenes are on any SUMO network (tests/recordings/test_network_scene.py drives one of several edges)."""
    network = one_edge_network(tmp_path, to_xy)
    start, end = read_lanes(network).shapes_m["road"][0][[0, -1]]
    along = (end - start) / np.linalg.norm(end - start)
    rows = [{**row, "pos": row["x"], "x": start[0] + row["x"] * along[0], "y": start[1] + row["x"] * along[1]}
            for row in fcd_vehicle("a", range(20), 50.0, 0.0, "road_0")]
    result = invoke("--format", "fcd", str(write_fcd(tmp_path / "fcd.xml", rows)), "--network", str(network),
                    "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0 and "kept 1 tracks" in result.output, result.output


def test_bom_headers_are_read_as_the_columns_they_name(tmp_path):
    rows = [row for vehicle in range(1, 4) for row in highd_vehicle(vehicle, range(1, 40), 10.0 * vehicle, 6,
                                                                    upper=False)]
    recording = write_highd(tmp_path, rows)
    ngsim_file = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 30), 40.0, 2))
    for path in (recording, tmp_path / "01_tracksMeta.csv", tmp_path / "01_recordingMeta.csv", ngsim_file):
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    for args in (("--format", "highd", str(recording)), ("--format", "ngsim", str(ngsim_file))):
        result = invoke(*args, "--out", str(tmp_path / args[1]))
        assert result.exit_code == 0 and "kept" in result.output, result.output


def test_a_gzip_ngsim_file_is_read_whatever_its_name_and_other_binary_is_one_printable_sentence(tmp_path):
    plain = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 30), 40.0, 2))
    for name in ("t.csv.gz", "packed.csv"):
        (tmp_path / name).write_bytes(gzip.compress(plain.read_bytes()))
        result = invoke("--format", "ngsim", str(tmp_path / name), "--out", str(tmp_path / f"scene_{name}"))
        assert result.exit_code == 0 and "kept 1 tracks" in result.output, result.output
    (tmp_path / "image.csv").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x07\x1b[31m\xff\xfe")
    output = refused(tmp_path, 2, "--format", "ngsim", str(tmp_path / "image.csv"))
    assert "image.csv is not a text file: it holds binary bytes" in output
    assert output.isascii() and all(char.isprintable() for char in output.strip())


def test_an_ngsim_csv_without_its_header_line_is_one_sentence(tmp_path):
    path = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 30), 40.0, 2))
    path.write_text("".join(path.read_text().splitlines(keepends=True)[1:]))
    assert "t.csv has no header line: an NGSIM CSV begins with its column names" in refused(
        tmp_path, 2, "--format", "ngsim", str(path))


@pytest.mark.parametrize(("vehicles", "message"), [("30-25", "the range 30-25 is empty"),
                                                   (",", "',' names no vehicle")])
def test_a_vehicle_selection_that_selects_nothing_is_refused(tmp_path, vehicles, message):
    path = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(27, range(1, 30), 40.0, 2))
    assert message in refused(tmp_path, 2, "--format", "ngsim", str(path), "--vehicles", vehicles)


def test_a_gzip_network_is_taken_as_scenario_network_takes_it(tmp_path):
    network = fcd_network(tmp_path)
    packed = tmp_path / "net.net.xml.gz"
    packed.write_bytes(gzip.compress(network.read_bytes()))
    result = invoke("--format", "fcd", str(write_fcd(tmp_path / "fcd.xml", fcd_rows())), "--network", str(packed),
                    "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0 and "kept 2 tracks" in result.output, result.output
    assert json.loads((tmp_path / "scene" / "scene.json").read_text())["network"] == str(packed.resolve())
    packed.write_bytes(packed.read_bytes()[:200])  # cut short
    output = refused(tmp_path / "scene", 2, "--format", "fcd", str(tmp_path / "fcd.xml"), "--network", str(packed))
    assert f"cannot read network {packed}: it is a damaged gzip file" in output


def test_an_import_into_an_out_another_command_writes_is_one_sentence_and_nothing_written(tmp_path):
    path = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 30), 40.0, 2))
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(tmp_path / "scene").write_text(f"{holder.pid}\n")
        output = refused(tmp_path, 1, "--format", "ngsim", str(path))
        assert f"is being written by another sumo-rail command (pid {holder.pid})" in output
    finally:
        holder.kill()
        holder.wait()
    result = invoke("--format", "ngsim", str(path), "--out", str(tmp_path / "scene"))
    assert result.exit_code == 0 and not lock_path(tmp_path / "scene").exists(), result.output
