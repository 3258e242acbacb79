"""The highD reader on files written to the published format: box corners, both driving directions, the lanes."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import LOWER_MARKINGS, UPPER_MARKINGS, highd_vehicle, write_highd
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.recordings import highd
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import OPPOSITE_EDGE, ROAD_EDGE, read_lanes
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.scene_observations import SceneFrames
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.tracks import RecordingDataError, RecordingUsageError
from sumo_rail.sim.actions import Action


@pytest.fixture
def recording(tmp_path):
    rows = (highd_vehicle(1, range(1, 51), 300.0, 2, upper=True)      # upper, rightmost lane (top)
            + highd_vehicle(2, range(1, 51), 20.0, 6, upper=False)    # lower, rightmost lane (bottom)
            + highd_vehicle(3, range(11, 61), 40.0, 5, upper=False, length=12.0, width=2.5))  # lower, leftmost
    return write_highd(tmp_path, rows, classes={3: "Truck"})


def test_the_lower_direction_is_read_at_the_front_bumper_in_sumo_lanes(recording):
    read = highd.read([recording], ReadOptions(direction="lower"))
    tracks = read.tracks.set_index(["vehicle_id", "frame"])
    assert sorted(read.tracks["vehicle_id"].unique()) == ["2", "3"]
    car = tracks.loc[("2", 1)]
    assert car["x_m"] == pytest.approx(20.0 + 4.5)  # top-left corner + box width = front bumper
    assert car["y_m"] == pytest.approx(LOWER_MARKINGS[0] - (LOWER_MARKINGS[1] + LOWER_MARKINGS[2]) / 2)
    assert car["lane"] == 0 and tracks.loc[("3", 11), "lane"] == 1  # lane 6 (bottom) rightmost, lane 5 leftmost
    assert car["heading_deg"] == pytest.approx(90.0) and car["speed_mps"] == pytest.approx(30.0)
    assert tracks.loc[("3", 11), "time_s"] == pytest.approx(10 / 25)
    assert tracks.loc[("3", 11), "vehicle_class"] == "truck" and tracks.loc[("3", 11), "length_m"] == 12.0
    assert read.lane_widths_m == pytest.approx((18.25 - 14.5, 14.5 - 11.0))  # rightmost first
    assert "upper driving direction" in read.notes[0]


def test_the_upper_direction_runs_along_x_from_the_image_right(recording):
    read = highd.read([recording], ReadOptions(direction="upper"))
    car = read.tracks.sort_values("frame")
    assert list(car["vehicle_id"].unique()) == ["1"]
    # driven leftwards: the front is the box's left side, and the scene's x grows as the image x falls
    assert np.diff(car["x_m"].to_numpy()) == pytest.approx(np.full(49, 30.0 / 25))
    assert car["lane"].iloc[0] == 0  # lane 2, the top lane of the upper carriageway, is its rightmost
    assert car["y_m"].iloc[0] == pytest.approx((UPPER_MARKINGS[0] + UPPER_MARKINGS[1]) / 2 - UPPER_MARKINGS[-1])
    assert car["heading_deg"].iloc[0] == pytest.approx(90.0)
    assert read.lane_widths_m == pytest.approx((3.5, 3.5))


def test_a_lane_off_its_markings_or_of_no_marking_is_refused(tmp_path):
    for offset_m in (-3.0, 3.0):  # above, below the lane
        shifted = write_highd(tmp_path, highd_vehicle(4, range(1, 30), 20.0, 6, upper=False, y_offset=offset_m))
        with pytest.raises(RecordingDataError, match="vehicle 4 at frame 1 is in lane 6 but its centre y"):
            highd.read([shifted], ReadOptions(direction="lower"))
    unknown = write_highd(tmp_path, highd_vehicle(5, range(1, 30), 20.0, 6, upper=False), stem="02")
    text = unknown.read_text().replace(",6\n", ",7\n")
    unknown.write_text(text)
    with pytest.raises(RecordingDataError, match="lane 7 of vehicle 5 at frame 1 is not a lane of the lower"):
        highd.read([unknown], ReadOptions(direction="lower"))


def test_headers_other_than_highds_are_refused_naming_the_column(recording):
    highd.check_headers([recording])
    recording.write_text(recording.read_text().replace("xVelocity", "xSpeed", 1))
    with pytest.raises(RecordingUsageError, match="lacks the column 'xVelocity'"):
        highd.check_headers([recording])


def test_the_three_files_of_one_recording_are_needed(recording):
    (recording.parent / "01_recordingMeta.csv").unlink()
    with pytest.raises(RecordingUsageError, match=r"01_recordingMeta\.csv does not exist"):
        highd.check_headers([recording])


def sideways(rows: list[dict], speed_y: float) -> list[dict]:
    """`rows` of one vehicle moving down the image at `speed_y` [m/s] (highD's y points down), frame by frame."""
    return [dict(row, y=row["y"] + speed_y * k / 25.0, yVelocity=speed_y) for k, row in enumerate(rows)]


def test_a_sideways_speed_moves_and_turns_each_direction_toward_its_own_side(tmp_path):
    """Down the image is the upper direction's left (driven leftwards) and the lower direction's right."""
    recording = write_highd(tmp_path, sideways(highd_vehicle(1, range(1, 30), 300.0, 2, upper=True), 1.0)
                            + sideways(highd_vehicle(2, range(1, 30), 20.0, 6, upper=False), 1.0))
    turn = np.degrees(np.arctan2(1.0, 30.0))
    for direction, side in (("upper", 1.0), ("lower", -1.0)):  # to the left: +y, heading below 90 deg
        track = highd.read([recording], ReadOptions(direction=direction)).tracks.sort_values("frame")
        assert np.diff(track["y_m"].to_numpy()) == pytest.approx(np.full(28, side / 25.0)), direction
        assert track["heading_deg"].to_numpy() == pytest.approx(np.full(29, 90.0 - side * turn)), direction


def test_at_25_hz_an_instant_between_frames_is_interpolated_toward_the_next(tmp_path):
    """Decision instants and SUMO steps fall between highD's frames (0.5 s is 12.5 frames): the scene's vehicles
    there are interpolated linearly between the frames around it, the heading too."""
    rows = sideways(highd_vehicle(1, range(1, 40), 20.0, 6, upper=False), 1.0)
    for k, row in enumerate(rows):
        t = k / 25.0
        row.update(x=20.0 + 20.0 * t + t**2, xVelocity=20.0 + 2.0 * t, yVelocity=1.0 + t)
    read = highd.read([write_highd(tmp_path, rows)], ReadOptions(direction="lower"))
    track = read.tracks.sort_values("time_s")
    frames = SceneFrames(read.tracks, read.frame_rate_hz)
    for instant in (0.49, 0.5, 0.51, 0.52):  # 12.25, 12.5, 12.75 frames (between two), 13 (a frame)
        _, values, _ = frames.at(instant)
        for column in ("x_m", "y_m", "speed_mps", "heading_deg"):
            expected = np.interp(instant, track["time_s"], track[column])
            assert values[column][0] == pytest.approx(expected, abs=1e-9), (instant, column)
    _, values, _ = frames.at(0.49)
    assert values["x_m"][0] != pytest.approx(track["x_m"].iloc[12]) and values["x_m"][0] != pytest.approx(
        track["x_m"].iloc[13])


def test_both_directions_are_one_scene_each_on_its_own_carriageway(tmp_path):
    """--direction both: the lower direction exactly as in its own scene, the upper one on the other carriageway's
    edge, driven toward -x; every row on the lane it names, at its position along it; a seat there drives that way."""
    rows = (highd_vehicle(1, range(1, 251), 400.0, 2, upper=True)
            + highd_vehicle(2, range(1, 251), 20.0, 6, upper=False)
            + highd_vehicle(3, range(1, 251), 60.0, 5, upper=False))
    recording = write_highd(tmp_path, rows)
    for direction in ("both", "lower"):
        result = CliRunner().invoke(cli, ["import-recording", "--format", "highd", str(recording), "--direction",
                                          direction, "--out", str(tmp_path / direction)])
        assert result.exit_code == 0, result.output
    both, lower = read_scene(tmp_path / "both"), read_scene(tmp_path / "lower")
    assert both.meta.direction == "both" and set(both.tracks["edge"]) == {ROAD_EDGE, OPPOSITE_EDGE}
    columns = ["vehicle_id", "time_s", "x_m", "y_m", "heading_deg", "lane", "lane_position_m"]
    pd.testing.assert_frame_equal(both.tracks[both.tracks["edge"] == ROAD_EDGE][columns].reset_index(drop=True),
                                  lower.tracks[columns].reset_index(drop=True))
    lanes = read_lanes(both.network)
    for (edge, lane), on in both.tracks.groupby(["edge", "lane"]):
        start, end = lanes.shapes_m[edge][lane][[0, -1]]
        along = (end - start) / np.linalg.norm(end - start)
        offset = on[["x_m", "y_m"]].to_numpy() - start
        # on its centre line (which the network file holds to 0.01 m), at its position along it
        assert np.abs(offset @ np.array([-along[1], along[0]])) == pytest.approx(0.0, abs=0.006)
        assert offset @ along == pytest.approx(on["lane_position_m"].to_numpy(), abs=0.006)
    config = Config.from_dict({"scenario": {"lanes": 2, "speed_limit_mps": 44.44}, "env": {
        "v_max_mps": 44.44, "ego_start_min_m": 0.0, "ego_start_max_m": 10.0, "end_margin_m": 10.0}})
    env = SceneEnv(config, tmp_path / "both")
    env.reset(seed=0, options={"vehicle": "1", "start_s": 1.0})
    ego = env.traffic.ego
    assert ego.lane_id == f"{OPPOSITE_EDGE}_0" and np.cos(ego.heading_rad) == pytest.approx(-1.0)
    env.step(int(Action.KEEP))
    assert env.traffic.ego.front_x < ego.front_x - 10.0  # 0.5 s at 30 m/s toward -x
    env.close()
    result = CliRunner().invoke(cli, ["recorded-demos", str(tmp_path / "both"), "--set", "scenario.lanes=2", "--set",
                                      "scenario.speed_limit_mps=44.44", "--set", "env.v_max_mps=44.44", "--set",
                                      "observation.lane_block=1", "--set", "observation.route_block=1", "--split",
                                      "train", "--out", str(tmp_path / "demos.parquet")])
    assert result.exit_code == 0, result.output
    demos = pd.read_parquet(tmp_path / "demos.parquet")
    assert (demos.groupby("episode")["position_m"].diff().dropna() > 0).all()  # each along its own carriageway
    assert np.isfinite(np.stack(demos["observation"].to_numpy())).all()  # the other carriageway's cars in sight too


def test_an_upper_lane_change_is_read_at_its_onset_in_a_scene_of_both_directions_as_in_its_own(tmp_path):
    """The upper carriageway of --direction both is driven toward -x, so its left is -y: its lane changes are read at
    the onset of the sideways motion, the same decision as in the upper direction's own scene (were: at the crossing,
    1.5 s later here, the motion read as away from the new lane)."""
    rows = highd_vehicle(1, range(1, 300), 420.0, 2, upper=True) + highd_vehicle(2, range(1, 300), 20.0, 6, upper=False)
    for k, row in enumerate(rows[:299]):  # from 2 s on, down the image (the upper direction's left) into lane 3
        row["y"] += min(max(k - 50, 0) / 25.0, UPPER_MARKINGS[2] - UPPER_MARKINGS[1])
        row["laneId"] = 3 if row["y"] + row["height"] / 2 > UPPER_MARKINGS[1] else 2
    recording = write_highd(tmp_path, rows)
    read = {}
    for direction in ("both", "upper"):
        scene = tmp_path / direction
        for command in (["import-recording", "--format", "highd", str(recording), "--direction", direction,
                         "--test-share", "0", "--validation-share", "0", "--out", str(scene)],
                        ["recorded-demos", str(scene), "--set", "scenario.lanes=2", "--set",
                         "scenario.speed_limit_mps=44.44", "--set", "env.v_max_mps=44.44", "--split", "train",
                         "--out", str(tmp_path / f"{direction}.parquet")]):
            result = CliRunner().invoke(cli, command)
            assert result.exit_code == 0, result.output
        demos = pd.read_parquet(tmp_path / f"{direction}.parquet")
        read[direction] = demos.loc[demos["episode"] == demos["episode"].min(), "action"].tolist()
    assert read["upper"].count(Action.LANE_LEFT) == 1 and read["both"] == read["upper"]
