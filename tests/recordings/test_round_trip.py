"""A scene written in each format and read back gives back its tracks (within the formats' rounding); FCD's edges
are checked against the network."""

from __future__ import annotations

import gzip

import numpy as np
import pandas as pd
import pytest

from sumo_rail.recordings import fcd, highd, ngsim
from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import ROAD_EDGE, build_road, straight_road
from sumo_rail.recordings.tracks import RecordingDataError, RecordingUsageError

WIDTHS = (3.2, 3.2, 3.2)
CENTRES = (-8.0, -4.8, -1.6)
"""Lane centres [m] of the three 3.2 m lanes right of y = 0, rightmost first."""
POSITION_M, SPEED_MPS, HEADING_DEG = 0.01, 0.01, 0.5
"""Round-trip tolerances: the files keep 2 (FCD) or 3 decimals."""


def scene(rate_hz: float = 10.0) -> pd.DataFrame:
    """Three vehicles at 10 Hz: a car accelerating in lane 0, a truck in lane 2, a car changing from lane 1 to 2."""
    rows = []
    for vehicle, lane, x0, speed0, accel, length, width, cls in (("a", 0, 60.0, 25.0, 0.8, 4.5, 1.8, "passenger"),
                                                                  ("b", 2, 90.0, 22.0, 0.0, 12.0, 2.5, "truck"),
                                                                  ("c", 1, 40.0, 28.0, -0.5, 4.3, 1.8, "passenger")):
        t = np.arange(0.0, 8.0 + 1e-9, 1.0 / rate_hz) + (0.3 if vehicle == "c" else 0.0)
        rel = t - t[0]
        x = x0 + speed0 * rel + 0.5 * accel * rel ** 2
        y = np.full_like(t, CENTRES[lane])
        lanes = np.full(len(t), lane)
        heading = np.full_like(t, 90.0)
        if vehicle == "c":  # 2 s lane change to the left from 3 s
            moving = (rel >= 3.0) & (rel <= 5.0)
            y = np.where(rel < 3.0, CENTRES[1], np.where(rel > 5.0, CENTRES[2], CENTRES[1] + 1.6 * (rel - 3.0)))
            lanes = np.where(y > -3.2, 2, 1)
            heading = np.where(moving, 90.0 - np.degrees(np.arctan2(1.6, speed0 + accel * rel)), 90.0)
        rows.append(pd.DataFrame({
            "vehicle_id": vehicle, "time_s": t, "x_m": x, "y_m": y, "heading_deg": heading,
            "speed_mps": speed0 + accel * rel, "acceleration_mps2": accel, "edge": ROAD_EDGE, "lane": lanes,
            "lane_position_m": x, "length_m": length, "width_m": width, "vehicle_class": cls}))
    return pd.concat(rows, ignore_index=True)


def assert_same_tracks(original: pd.DataFrame, read: pd.DataFrame, heading_deg: float = HEADING_DEG) -> None:
    """Each read row equals the original at its time (interpolated between the original's rows)."""
    # the files number the vehicles in the order of their ids (highD, NGSIM) or keep them (FCD)
    mapping = dict(zip(sorted(read["vehicle_id"].unique(), key=lambda v: (len(v), v)),
                       sorted(original["vehicle_id"].unique()), strict=True))
    for read_id, track in read.groupby("vehicle_id"):
        source = original[original["vehicle_id"] == mapping[read_id]]
        times = track["time_s"].to_numpy()
        assert times.min() >= source["time_s"].min() - 1e-6 and times.max() <= source["time_s"].max() + 1e-6
        for column, tolerance in (("x_m", POSITION_M), ("y_m", POSITION_M), ("speed_mps", SPEED_MPS),
                                  ("acceleration_mps2", SPEED_MPS), ("heading_deg", heading_deg)):
            expected = np.interp(times, source["time_s"], source[column])
            assert track[column].to_numpy() == pytest.approx(expected, abs=tolerance), (read_id, column)
        assert track["length_m"].iloc[0] == pytest.approx(source["length_m"].iloc[0], abs=POSITION_M)
        assert track["vehicle_class"].iloc[0] == source["vehicle_class"].iloc[0]
        at_rows = np.isin(np.round(times, 6), np.round(source["time_s"].to_numpy(), 6))
        lanes = source.set_index(np.round(source["time_s"], 6))["lane"]
        assert (track["lane"].to_numpy()[at_rows] == lanes.loc[np.round(times[at_rows], 6)].to_numpy()).all()


def test_highd_round_trip_at_25_hz_with_box_corners(tmp_path):
    original = scene()
    paths = highd.write(original, WIDTHS, 400.0, tmp_path / "05")
    highd.check_headers(paths)
    read = highd.read([paths[0]], ReadOptions(direction="lower"))
    assert read.frame_rate_hz == 25.0 and read.lane_widths_m == pytest.approx(WIDTHS, abs=0.01)
    written = pd.read_csv(paths[0])
    first = written[written["id"] == 1].iloc[0]
    assert first["x"] == pytest.approx(60.0 - 4.5) and first["width"] == 4.5  # the box's left side, not the front
    assert_same_tracks(original, read.tracks)


def test_ngsim_round_trip_at_10_hz_in_feet(tmp_path):
    original = scene()
    path = ngsim.write(original, 3, tmp_path / "trajectories.csv")
    ngsim.check_headers([path])
    written = pd.read_csv(path)
    assert written["Lane_ID"].min() == 1 and written["Local_Y"].iloc[0] == pytest.approx(60.0 / 0.3048, abs=1e-3)
    read = ngsim.read([path], ReadOptions(site="us-101"))
    tracks = read.tracks.assign(lane=read.tracks["lane"] - 3)  # 3 lanes written, US-101's 6 read: lane 1 is leftmost
    assert_same_tracks(original, tracks, heading_deg=2.0)  # NGSIM has no heading: read from the positions


@pytest.mark.parametrize("name", ["fcd.xml", "fcd.xml.gz"])
def test_fcd_round_trip_against_the_network(tmp_path, name):
    build_road(list(WIDTHS), 400.0, tmp_path / "road.net.xml")
    assert straight_road(tmp_path / "road.net.xml") == pytest.approx(WIDTHS)
    original = scene()
    path = fcd.write(original, tmp_path / name)
    fcd.check_headers([path])
    read = fcd.read([path], ReadOptions(network=tmp_path / "road.net.xml"))
    assert read.frame_rate_hz == pytest.approx(10.0) and read.lanes == 3
    assert_same_tracks(original, read.tracks)


def test_fcd_edges_not_in_the_network_and_other_xml_are_refused(tmp_path):
    build_road(list(WIDTHS), 400.0, tmp_path / "road.net.xml")
    path = fcd.write(scene().assign(edge="elsewhere"), tmp_path / "fcd.xml")
    with pytest.raises(RecordingDataError, match="vehicle a at 0 s is on lane 'elsewhere_0', which the network"):
        fcd.read([path], ReadOptions(network=tmp_path / "road.net.xml"))
    with gzip.open(tmp_path / "routes.xml.gz", "wt") as file:
        file.write('<routes><vehicle id="x" depart="0"/></routes>')
    with pytest.raises(RecordingUsageError, match="its root element is <routes>, not <fcd-export>"):
        fcd.check_headers([tmp_path / "routes.xml.gz"])


def test_sumos_own_fcd_output_is_read_with_sizes_from_the_vehicle_types(tmp_path):
    """SUMO's default FCD attributes only (no acceleration, length, width), as `sumo --fcd-output` writes them."""
    build_road(list(WIDTHS), 400.0, tmp_path / "road.net.xml")
    steps = "".join(f'<timestep time="{t / 10:.2f}"><vehicle id="t1" x="{50 + 2 * t:.2f}" y="-8.00" angle="90.00" '
                    f'type="truck" speed="{20 + 0.1 * t:.2f}" pos="{50 + 2 * t:.2f}" lane="road_0" slope="0.00"/>'
                    f'</timestep>' for t in range(12))
    (tmp_path / "fcd.xml").write_text(f'<?xml version="1.0"?>\n<fcd-export>{steps}</fcd-export>')
    read = fcd.read([tmp_path / "fcd.xml"], ReadOptions(network=tmp_path / "road.net.xml"))
    assert read.tracks["length_m"].iloc[0] == 12.0 and read.tracks["vehicle_class"].iloc[0] == "truck"
    assert read.tracks["acceleration_mps2"].iloc[:-1].to_numpy() == pytest.approx(np.full(11, 1.0))
