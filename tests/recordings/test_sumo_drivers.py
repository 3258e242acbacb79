"""`sumo-rail record-sumo-drivers`: SUMO's own drivers recorded as a scene, the same bytes for a seed, over 500
tracks in the default duration, and the scene written as FCD and highD read back by import-recording."""

from __future__ import annotations

import json
import subprocess

import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from sumo_rail_cli.output_lock import lock_path

from sumo_rail.recordings import fcd, highd
from sumo_rail.recordings.scene import TRACK_SCHEMA
from sumo_rail.recordings.sumo_drivers import DRIVER_TYPES

FILES = ("road.net.xml", "scene.json", "split.parquet", "tracks.parquet")


def record(folder, *extra: str):
    result = CliRunner().invoke(cli, ["record-sumo-drivers", "--out", str(folder), *extra])
    assert result.exit_code == 0, result.output
    return result


@pytest.fixture(scope="module")
def short_scene(tmp_path_factory):
    """60 s of seed 3 after a 100 s warm-up."""
    folder = tmp_path_factory.mktemp("drivers") / "scene"
    record(folder, "--seed", "3", "--duration-s", "60", "--set", "scenario.warmup_s=100")
    return folder


def test_the_same_seed_gives_the_same_bytes_and_another_seed_other_traffic(short_scene, tmp_path):
    record(tmp_path / "again", "--seed", "3", "--duration-s", "60", "--set", "scenario.warmup_s=100")
    for name in FILES:
        assert (short_scene / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name
    record(tmp_path / "other", "--seed", "4", "--duration-s", "60", "--set", "scenario.warmup_s=100")
    ours, theirs = (pq.read_table(folder / "tracks.parquet").to_pandas()
                    for folder in (short_scene, tmp_path / "other"))
    assert len(ours) != len(theirs) or not ours["x_m"].equals(theirs["x_m"])  # the traffic, not only the metadata


def test_the_scene_holds_every_model_and_class_on_the_five_lanes(short_scene):
    tracks = pq.read_table(short_scene / "tracks.parquet")
    assert tracks.schema.remove_metadata() == TRACK_SCHEMA
    frame = tracks.to_pandas()
    assert set(frame["lane"]) == {0, 1, 2, 3, 4} and set(frame["vehicle_class"]) == {"passenger", "truck"}
    assert frame["time_s"].min() == 0.0 and frame["time_s"].max() == pytest.approx(59.9)
    lane_changes = (frame.groupby("vehicle_id")["lane"].nunique() > 1).sum()
    assert lane_changes >= 5
    # positions are front bumpers on the road along +x, left edge y = 0: lane k's centre at -(5 - k - 0.5) * 3.2
    steady = frame[frame["heading_deg"].round(3) == 90.0]
    assert (steady["y_m"] + (4.5 - steady["lane"]) * 3.2).abs().max() < 0.01
    speeds = frame.groupby("vehicle_id")["speed_mps"].max()
    assert speeds.std() > 2.0  # a spread of desired speeds
    scene = json.loads((short_scene / "scene.json").read_text())
    assert scene["format"] == "sumo" and scene["network"] == "road.net.xml" and scene["lanes"] == 5
    models = {values["carFollowModel"] for values in scene["settings"]["driver_types"].values()}
    assert models == {"Krauss", "IDM"} and all(float(v["sigma"]) > 0 for v in DRIVER_TYPES.values())
    split = pq.read_table(short_scene / "split.parquet").to_pandas()
    assert sorted(split["vehicle_id"]) == sorted(frame["vehicle_id"].unique())
    assert set(split["split"]) == {"train", "validation", "test"}


def test_the_default_duration_records_over_500_tracks(tmp_path):
    result = record(tmp_path / "scene", "--seed", "1")
    tracks = int(result.output.split("recorded ")[1].split(" tracks")[0])
    assert tracks >= 500
    assert pq.read_table(tmp_path / "scene" / "split.parquet").num_rows == tracks


def test_an_existing_scene_is_kept_without_overwrite(short_scene):
    result = CliRunner().invoke(cli, ["record-sumo-drivers", "--out", str(short_scene), "--seed", "3"])
    assert result.exit_code == 2 and "already holds a scene" in result.output


@pytest.mark.parametrize("form", ["fcd", "highd"])
def test_written_as_fcd_or_highd_it_reads_back_through_import_recording(short_scene, tmp_path, form):
    scene = pq.read_table(short_scene / "tracks.parquet").to_pandas()
    scene = scene[scene["vehicle_id"].isin(sorted(scene["vehicle_id"].unique())[:40])]
    if form == "fcd":
        files = [str(fcd.write(scene, tmp_path / "fcd.xml"))]
        extra = ["--network", str(short_scene / "road.net.xml")]
    else:
        files = [str(path) for path in highd.write(scene, (3.2,) * 5, 3000.0, tmp_path / "01")]
        extra = []
    result = CliRunner().invoke(cli, ["import-recording", "--format", form, *files, "--out", str(tmp_path / "read"),
                                      *extra])
    assert result.exit_code == 0, result.output
    assert "kept 40 tracks" in result.output
    read = pq.read_table(tmp_path / "read" / "tracks.parquet").to_pandas()
    if form == "fcd":  # FCD keeps the ids and SUMO's 10 Hz
        merged = read.merge(scene, on=["vehicle_id", "time_s"], suffixes=("", "_scene"))
        assert len(merged) == len(scene)
    else:  # highD numbers the vehicles in the order of their ids and resamples to 25 Hz
        mapping = dict(zip([str(k) for k in range(1, 41)], sorted(scene["vehicle_id"].unique(),
                                                                  key=lambda v: (len(v), v)), strict=True))
        read = read.assign(vehicle_id=read["vehicle_id"].map(mapping), time_s=read["time_s"].round(6))
        merged = read.merge(scene.assign(time_s=scene["time_s"].round(6)), on=["vehicle_id", "time_s"],
                            suffixes=("", "_scene"))
        assert len(merged) >= 0.19 * len(read)  # every 0.2 s a 25 Hz frame is a 10 Hz row
    for column in ("x_m", "y_m", "speed_mps"):
        assert (merged[column] - merged[f"{column}_scene"]).abs().max() < 0.01, column
    assert (merged["lane"] == merged["lane_scene"]).all()
    assert pd.Series(merged["vehicle_class"] == merged["vehicle_class_scene"]).all()


def test_the_warm_up_and_flow_are_the_scenarios_settings(short_scene):
    """scenario.warmup_s and scenario.flow_veh_per_h are the recording's (no option shadows them): scene.json says."""
    settings = json.loads((short_scene / "scene.json").read_text())["settings"]
    assert settings["warmup_s"] == 100.0 and settings["flow_veh_per_h"] == 4000.0


def refused(tmp_path, *extra: str, code: int = 2) -> str:
    """Run record-sumo-drivers into tmp_path/scene expecting a one-sentence refusal with exit `code` and nothing
    written; its output."""
    result = CliRunner().invoke(cli, ["record-sumo-drivers", "--out", str(tmp_path / "scene"), *extra])
    assert result.exit_code == code, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()[-1]) < 300
    assert not (tmp_path / "scene").exists() and sorted(tmp_path.iterdir()) == []
    return result.output


@pytest.mark.parametrize(("extra", "named"), [
    (["--seed", "2147483648"], "2147483647"),  # SUMO's seed range, as scenario.traffic_seed's
    (["--seed", "1", "--flow-veh-per-h", "29000"], "--flow-veh-per-h"),  # the setting is the one word for the flow
    (["--seed", "1", "--warmup-s", "0"], "--warmup-s"),
    (["--seed", "1", "--set", "scenario.lanes=2", "--set", "scenario.flow_veh_per_h=6500"], "scenario.flow_veh_per_h"),
    (["--seed", "1", "--duration-s", "1", "--set", "scenario.kind=merge"], "scenario.kind merge"),
    (["--seed", "1", "--duration-s", "1", "--set", "env.decision_period_s=2"], "--duration-s 1"),
])
def test_what_cannot_be_recorded_is_one_sentence_and_nothing_written(tmp_path, extra, named):
    assert named in refused(tmp_path, *extra)


def test_a_user_network_is_checked_as_every_command_checks_it(tmp_path):
    """record-sumo-drivers takes a user's network (tests/recordings/test_network_scene.py records on one); a route
    not in it is one sentence before any work."""
    from sumo_rail.recordings.road import build_road

    network = tmp_path.parent / f"{tmp_path.name}.net.xml"
    build_road([3.2] * 5, 3000.0, network)
    output = refused(tmp_path, "--seed", "1", "--duration-s", "1", "--set", "scenario.kind=network", "--set",
                     f"scenario.network={network}", "--set", "scenario.route=nowhere")
    assert "scenario.route's edge 'nowhere' is not in" in output


def test_a_recording_that_keeps_no_track_is_refused_and_nothing_written(tmp_path):
    output = refused(tmp_path, "--seed", "1", "--duration-s", "1", "--set", "scenario.warmup_s=0", code=1)
    assert "no vehicle" in output and "--duration-s" in output


def test_a_scene_another_command_writes_is_one_sentence_and_left_alone(tmp_path):
    out = tmp_path / "scene"
    holder = subprocess.Popen(["sleep", "600"])
    try:
        lock_path(out).write_text(f"{holder.pid}\n")
        result = CliRunner().invoke(cli, ["record-sumo-drivers", "--out", str(out), "--seed", "1", "--duration-s",
                                          "1", "--set", "scenario.warmup_s=0"])
        assert result.exit_code == 1 and f"pid {holder.pid}" in result.output and "Traceback" not in result.output
        assert not out.exists() and lock_path(out).read_text() == f"{holder.pid}\n"
    finally:
        holder.kill()
        holder.wait()
