"""The NGSIM reader on files written to the published data dictionary: feet, lanes from the left, reused ids."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from recording_files import ngsim_vehicle, write_ngsim
from sumo_rail_cli.main import cli

from sumo_rail.recordings import ngsim
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.ngsim import FEET_M
from sumo_rail.recordings.road import OFF_RAMP_EDGE, ON_RAMP_EDGE, ROAD_EDGE, read_lanes
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.tracks import (
    DROP_REASONS,
    GAP,
    TOO_SHORT,
    RecordingDataError,
    RecordingUsageError,
    kept_tracks,
)
from sumo_rail.sim.actions import Action


def test_feet_and_lanes_from_the_left_become_metres_and_sumo_lanes(tmp_path):
    path = write_ngsim(tmp_path / "us101.csv", ngsim_vehicle(1, range(5, 25), 100.0, 1, speed_ftps=60.0, v_class=3)
                       + ngsim_vehicle(2, range(5, 25), 200.0, 5))
    read = ngsim.read([path], ReadOptions(site="us-101"))
    first = read.tracks.sort_values(["vehicle_id", "frame"]).groupby("vehicle_id").first()
    assert first.loc["1", "x_m"] == pytest.approx(100.0 * FEET_M)
    assert first.loc["1", "y_m"] == pytest.approx(-6.0 * FEET_M)  # Local_X 6 ft from the left edge
    assert first.loc["1", "speed_mps"] == pytest.approx(60.0 * FEET_M)
    assert first.loc["1", "length_m"] == pytest.approx(15.0 * FEET_M) and first.loc["1", "width_m"] == pytest.approx(
        6.0 * FEET_M)
    assert first.loc["1", "lane"] == 5 and first.loc["2", "lane"] == 1  # lane 1 is the leftmost of six
    assert first.loc["1", "vehicle_class"] == "truck" and first.loc["1", "time_s"] == pytest.approx(0.4)
    assert first.loc["1", "heading_deg"] == pytest.approx(90.0)
    assert read.lanes == 6 and read.lane_widths_m == pytest.approx((12 * FEET_M,) * 6)  # and the auxiliary lane


def test_a_reused_id_is_split_and_a_gap_drops_the_track_and_a_ramp_does_not(tmp_path):
    rows = (ngsim_vehicle(7, range(1, 31), 0.0, 2, total_frames=30)
            + ngsim_vehicle(7, range(200, 241), 0.0, 3, length_ft=40.0, total_frames=41)  # another vehicle, same id
            + ngsim_vehicle(8, [*range(1, 20), *range(25, 40)], 0.0, 2)                   # same vehicle, 5 frames lost
            + ngsim_vehicle(9, range(1, 40), 0.0, 7)                                      # the on-ramp
            + ngsim_vehicle(10, range(1, 5), 0.0, 2))                                     # 0.3 s
    read = ngsim.read([write_ngsim(tmp_path / "t.csv", rows)], ReadOptions(site="us-101"))
    kept, dropped = kept_tracks(read.tracks, read.frame_rate_hz, 0.5, "t.csv", gaps_fail=False)
    assert sorted(kept["vehicle_id"].unique()) == ["7", "7#2", "9"]
    assert kept.groupby("vehicle_id")["length_m"].first().to_dict() == pytest.approx(
        {"7": 15.0 * FEET_M, "7#2": 40.0 * FEET_M, "9": 15.0 * FEET_M})
    assert dropped == {"8": GAP, "10": TOO_SHORT}


def test_lane_six_is_the_rightmost_through_lane_a_main_one_on_i80_and_auxiliary_on_us101(tmp_path):
    path = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 20), 0.0, 6))
    for site in ("i-80", "us-101"):
        read = ngsim.read([path], ReadOptions(site=site))
        assert read.tracks["lane"].iloc[0] == 0 and read.lanes == 6


def test_the_original_text_file_without_a_header_is_read(tmp_path):
    rows = ngsim_vehicle(3, range(1, 20), 50.0, 2)
    text = "\n".join("   ".join(str(value) for value in row.values()) for row in rows) + "\n"
    (tmp_path / "trajectories-0750am-0805am.txt").write_text(text)
    read = ngsim.read([tmp_path / "trajectories-0750am-0805am.txt"], ReadOptions(site="us-101"))
    assert len(read.tracks) == 19 and read.tracks["lane"].iloc[0] == 4


def test_a_renamed_column_is_refused_before_any_work(tmp_path):
    path = write_ngsim(tmp_path / "t.csv", ngsim_vehicle(1, range(1, 20), 0.0, 2))
    path.write_text(path.read_text().replace("Local_Y", "LocalY", 1))
    with pytest.raises(RecordingUsageError, match="lacks the column 'Local_Y'"):
        ngsim.check_headers([path])


def test_only_the_sites_rows_of_a_file_with_locations_are_read(tmp_path):
    rows = [dict(row, Location="us-101") for row in ngsim_vehicle(1, range(1, 20), 0.0, 2)]
    rows += [dict(row, Location="lankershim") for row in ngsim_vehicle(2, range(1, 20), 0.0, 2)]
    pd.DataFrame(rows).to_csv(tmp_path / "ngsim.csv", index=False)
    read = ngsim.read([tmp_path / "ngsim.csv"], ReadOptions(site="us-101"))
    assert read.tracks["vehicle_id"].unique().tolist() == ["1"]
    with pytest.raises(RecordingDataError, match="has no rows of i-80"):
        ngsim.read([tmp_path / "ngsim.csv"], ReadOptions(site="i-80"))


def test_the_data_transportation_gov_edition_is_read_as_the_original(tmp_path):
    """That edition writes v_length (not v_Length), adds zone and movement columns and Location, often a leading
    index column, and repeats some rows word for word; a repeated frame whose values differ is still refused."""
    rows = ngsim_vehicle(1, range(1, 30), 0.0, 2) + ngsim_vehicle(2, range(5, 40), 80.0, 3, length_ft=22.0)
    original = ngsim.read([write_ngsim(tmp_path / "original.csv", rows)], ReadOptions(site="us-101"))
    edition = pd.DataFrame(rows).rename(columns={"v_Length": "v_length"})
    edition[["O_Zone", "D_Zone", "Int_ID", "Section_ID", "Direction", "Movement"]] = 0
    edition["Location"] = "us-101"
    pd.concat([edition, edition.iloc[[3, 40]]]).to_csv(tmp_path / "edition.csv")  # with pandas' index column
    ngsim.check_headers([tmp_path / "edition.csv"])
    read = ngsim.read([tmp_path / "edition.csv"], ReadOptions(site="us-101"))
    pd.testing.assert_frame_equal(read.tracks, original.tracks)
    assert "2 row(s) repeated word for word left out" in read.notes
    conflicting = pd.concat([edition, edition.iloc[[3]].assign(Local_Y=1.0)])
    conflicting.to_csv(tmp_path / "conflicting.csv", index=False)
    with pytest.raises(RecordingDataError, match="vehicle 1 appears twice in frame 4"):
        kept_tracks(ngsim.read([tmp_path / "conflicting.csv"], ReadOptions(site="us-101")).tracks, 10.0, 0.5,
                    "conflicting.csv", gaps_fail=False)


def test_a_file_of_several_recording_periods_is_imported_one_period_at_a_time(tmp_path):
    """The data.transportation.gov edition holds a site's periods in one file, each counting its frames from 1 and
    reusing vehicle ids: the command names the periods, --period picks one, and only its vehicles are kept."""
    first = ngsim_vehicle(1, range(1, 40), 0.0, 2) + ngsim_vehicle(2, range(1, 40), 60.0, 3)
    later = [dict(row, Global_Time=row["Global_Time"] + 15 * 60 * 1000, Lane_ID=4)
             for row in ngsim_vehicle(1, range(1, 30), 100.0, 4) + ngsim_vehicle(3, range(1, 30), 30.0, 4)]
    path = write_ngsim(tmp_path / "ngsim.csv", later + first)
    runner = CliRunner()
    refused = runner.invoke(cli, ["import-recording", "--format", "ngsim", str(path), "--out", str(tmp_path / "all")])
    assert refused.exit_code == 1 and "holds 2 recording periods (starting 2005-06-15 " in refused.output
    assert "with --period 1 to 2" in refused.output and not (tmp_path / "all").exists()
    for period, vehicles, lane in ((1, {"1", "2"}, {4, 3}), (2, {"1", "3"}, {2})):
        out = tmp_path / f"period{period}"
        done = runner.invoke(cli, ["import-recording", "--format", "ngsim", str(path), "--period", str(period),
                                   "--test-share", "0", "--validation-share", "0", "--out", str(out)])
        assert done.exit_code == 0, done.output
        assert f"recording period {period} of 2, starting 2005-06-15" in done.output
        tracks = read_scene(out).tracks
        assert set(tracks["vehicle_id"]) == vehicles and set(tracks["lane"]) == lane
    beyond = runner.invoke(cli, ["import-recording", "--format", "ngsim", str(path), "--period", "3",
                                 "--out", str(tmp_path / "none")])
    assert beyond.exit_code == 1 and "--period 3: " in beyond.output and "holds 2 recording period(s)" in beyond.output
    other = runner.invoke(cli, ["import-recording", "--format", "highd", str(path), "--period", "1",
                                "--out", str(tmp_path / "highd")])
    assert other.exit_code == 2 and "--period applies to --format ngsim only" in other.output


def test_a_track_of_exactly_one_decisions_frames_is_kept_and_one_frame_less_is_too_short(tmp_path):
    """At 10 Hz a 0.5 s decision needs 6 frames: its period's 5 and the one after it."""
    rows = ngsim_vehicle(1, range(1, 7), 0.0, 2) + ngsim_vehicle(2, range(1, 6), 50.0, 2)
    read = ngsim.read([write_ngsim(tmp_path / "t.csv", rows)], ReadOptions(site="us-101"))
    kept, dropped = kept_tracks(read.tracks, read.frame_rate_hz, 0.5, "t.csv", gaps_fail=False)
    assert kept["vehicle_id"].unique().tolist() == ["1"] and dropped == {"2": TOO_SHORT}


def test_a_track_that_fails_several_checks_is_dropped_for_the_first_documented_reason(tmp_path):
    assert DROP_REASONS == (GAP, TOO_SHORT)
    rows = (ngsim_vehicle(1, [1, 2, 5], 0.0, 7)             # the on-ramp, a gap, 3 frames
            + ngsim_vehicle(2, [1, 2, 3, 9, 10], 100.0, 2)  # a gap, 5 frames
            + ngsim_vehicle(3, range(1, 4), 200.0, 8)       # the off-ramp, 3 frames
            + ngsim_vehicle(4, range(1, 30), 300.0, 2))
    read = ngsim.read([write_ngsim(tmp_path / "t.csv", rows)], ReadOptions(site="us-101"))
    kept, dropped = kept_tracks(read.tracks, read.frame_rate_hz, 0.5, "t.csv", gaps_fail=False)
    assert dropped == {"1": GAP, "2": GAP, "3": TOO_SHORT} and kept["vehicle_id"].unique().tolist() == ["4"]


def changing(vehicle: int, lanes_by_frame: dict[int, int], local_y_ft: float) -> list[dict]:
    """Rows of one NGSIM vehicle at 50 ft/s whose lane is `lanes_by_frame`'s for each frame (centred in it; either
    ramp, 7 or 8, one 12 ft strip right of the auxiliary lane 6)."""
    rows = ngsim_vehicle(vehicle, range(1, len(lanes_by_frame) + 1), local_y_ft, 2)
    for row in rows:
        lane = lanes_by_frame[row["Frame_ID"]]
        row.update(Lane_ID=lane, Local_X=12.0 * min(lane, 7) - 6.0)
    return rows


def test_ramp_vehicles_are_kept_on_a_road_built_with_the_ramp_lane_and_their_merges_read(tmp_path):
    """On US-101 a car enters from the on-ramp (lane 7) into the auxiliary lane (6), another leaves from it by the
    off-ramp (8): both kept, on a road whose ramp lane runs beside the on-ramp's stretch and the off-ramp's; every row
    on the lane it names; recorded-demos reads the merge as a change to the left and the exit to the right."""
    rows = (changing(1, {frame: 7 if frame <= 40 else 6 for frame in range(1, 101)}, 0.0)
            + changing(2, {frame: 6 if frame <= 60 else 8 for frame in range(1, 101)}, 100.0)
            + ngsim_vehicle(3, range(1, 101), 50.0, 3))
    recording = write_ngsim(tmp_path / "t.csv", rows)
    result = CliRunner().invoke(cli, ["import-recording", "--format", "ngsim", str(recording), "--site", "us-101",
                                      "--test-share", "0", "--validation-share", "0", "--out", str(tmp_path / "scene")])
    assert result.exit_code == 0 and "kept 3 tracks, dropped 0" in result.output, result.output
    scene = read_scene(tmp_path / "scene")
    lanes = read_lanes(scene.network)
    assert {lanes.lanes(edge) for edge in (ON_RAMP_EDGE, ROAD_EDGE, OFF_RAMP_EDGE)} == {7, 6}
    assert {ON_RAMP_EDGE, ROAD_EDGE, OFF_RAMP_EDGE} <= set(scene.tracks["edge"])
    for (edge, lane), on in scene.tracks.groupby(["edge", "lane"]):
        shape = lanes.shapes_m[edge][lane]
        assert lanes.widths_m[edge][lane] == pytest.approx(12 * FEET_M, abs=0.005)
        straight = np.abs(shape[:, 1] - shape[0, 1]).max() < 1e-6
        if straight:  # on its centre line, at its position along it (junctions' bending lanes aside)
            assert on["y_m"].to_numpy() == pytest.approx(shape[0, 1], abs=0.006)
            assert on["lane_position_m"].to_numpy() == pytest.approx(on["x_m"].to_numpy() - shape[0, 0], abs=1e-6)
    result = CliRunner().invoke(cli, ["recorded-demos", str(tmp_path / "scene"), "--set", "scenario.lanes=7", "--set",
                                      "scenario.speed_limit_mps=44.44", "--set", "env.v_max_mps=44.44",
                                      "--out", str(tmp_path / "demos.parquet")])
    assert result.exit_code == 0, result.output
    demos = pd.read_parquet(tmp_path / "demos.parquet")
    changes = demos[demos["action"].isin([Action.LANE_LEFT, Action.LANE_RIGHT])]
    assert changes.groupby("episode")["action"].apply(list).to_dict() == {0: [Action.LANE_LEFT],
                                                                          1: [Action.LANE_RIGHT]}
