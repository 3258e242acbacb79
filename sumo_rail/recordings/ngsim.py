"""NGSIM US-101 and I-80 vehicle trajectories (FHWA, public): read into a scene, and write a scene out.

A file is the trajectory CSV with a header of `COLUMNS` (the extra columns of the data.transportation.gov edition,
Location among them, are allowed, and its spelling v_length), or the original whitespace-separated text file of those 18
columns without a header; either may be gzip-compressed. Units are feet, ft/s and ft/s^2 at 10 Hz (Frame_ID counts
tenths of a second from 1 in each recording period; files holding several periods, as that edition does, are read one
period at a time, `ReadOptions.period`). Rows repeated word for word (that edition has some) are read once. Local_Y is
the front of the vehicle along the road from the section's entry, Local_X the lateral position of its front centre from
the section's left edge. Lane_ID 1 is the leftmost lane: US-101 has main lanes 1 to 5, an auxiliary lane 6, an on-ramp 7
and an off-ramp 8; I-80 main lanes 1 to 6 and an on-ramp 7. Every track is kept, on a road built with the lanes the
recording uses. A Vehicle_ID is reused for another vehicle after the first one left: a track is split where the
vehicle's Total_Frames, v_Length, v_Width or v_Class change ("17", "17#2"); a gap with none of them changing is a gap in
frames and the track is dropped. A vehicle drives toward growing Local_Y: a track that falls back more than
BACKWARD_TOLERANCE_M is refused.

The scene's road runs straight along +x with the site's through lanes (`THROUGH_LANES`: the main lanes and US-101's
auxiliary lane), 12 ft (3.6576 m) each, left edge at y = 0; x is Local_Y and y minus Local_X, in metres. Where the
recording has vehicles on a ramp, the road has one more lane on the right (lanes 7 and 8 lie there, one 12 ft strip
right of the auxiliary lane): from its start to `RAMP_MARGIN_M` past the farthest on-ramp front (edge
`road.ON_RAMP_EDGE`, merging into the rightmost through lane), and from `RAMP_MARGIN_M` before the nearest off-ramp
front to its end (`road.OFF_RAMP_EDGE`, leaving it); where those would leave less than `MIN_THROUGH_M` between them,
the ramp lane runs the whole section. Each row's edge, lane and lane position are read off that road.
"""

from __future__ import annotations

import tempfile
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import build_road, place_on_road
from sumo_rail.recordings.tracks import (
    Recording,
    RecordingDataError,
    RecordingUsageError,
    check_columns,
    check_limits,
    check_numbers,
    check_positions,
    heading_deg,
    read_csv,
    road_length_m,
    text_head,
)
from sumo_rail.recordings.writing import NO_VEHICLE, headways, neighbours, resampled

COLUMNS = ("Vehicle_ID", "Frame_ID", "Total_Frames", "Global_Time", "Local_X", "Local_Y", "Global_X", "Global_Y",
           "v_Length", "v_Width", "v_Class", "v_Vel", "v_Acc", "Lane_ID", "Preceding", "Following", "Space_Headway",
           "Time_Headway")
FEET_M = 0.3048
LANE_WIDTH_M = 12 * FEET_M
FRAME_RATE_HZ = 10.0
MAIN_LANES = {"us-101": 5, "i-80": 6}
"""Each site's main lanes (Lane_ID 1 .. n); higher lane ids are the auxiliary lane and the ramps."""
THROUGH_LANES = {"us-101": 6, "i-80": 6}
"""Each site's lanes along the whole section (Lane_ID 1 .. n): the main lanes and US-101's auxiliary lane 6."""
ON_RAMP_ID, OFF_RAMP_ID = 7, 8
HIGHEST_LANE_ID = 8
RAMP_MARGIN_M = 5.0
"""The ramp lane ends this far past the farthest on-ramp front, and begins this far before the nearest off-ramp front
[m] (beyond the junction netconvert builds there, 4 m either side)."""
MIN_THROUGH_M = 20.0
"""The shortest stretch without the ramp lane between an on-ramp and an off-ramp [m]."""
TRUCK_CLASS = 3
"""v_Class: 1 motorcycle, 2 automobile, 3 truck."""
BACKWARD_TOLERANCE_M = 1.0
"""A track whose front falls back this far [m] behind where it was (its frames running backwards along the road) is
broken; less is the positions' noise."""
_CANONICAL = {name.casefold(): name for name in (*COLUMNS, "Location")}
"""A header's names as this module spells them: the data.transportation.gov edition writes v_length, the original
files v_Length."""
_IDENTITY = ("Total_Frames", "v_Length", "v_Width", "v_Class")
_READ = ("Vehicle_ID", "Frame_ID", *_IDENTITY, "Global_Time", "Local_X", "Local_Y", "v_Vel", "v_Acc", "Lane_ID")
PERIOD_GAP_S = 60.0
"""Rows whose Global_Time minus their Frame_ID's time differ by more than this [s] are of different recording periods
(each period counts its frames from 1; the data.transportation.gov edition holds a site's periods in one file)."""


def _header(path: Path) -> tuple[list[str], bool]:
    """The file's column names and whether it has a header line (else the 18 columns of the original text file);
    RecordingUsageError for a file of numbers that is neither."""
    first = text_head(path)[0]
    fields = first.replace(",", " ").split()
    numbers = bool(fields) and all(_is_number(value) for value in fields)
    if numbers and "," in first:
        raise RecordingUsageError(f"{path} has no header line: an NGSIM CSV begins with its column names "
                                  f"({','.join(COLUMNS[:3])},...); only the original text files, whitespace-separated, "
                                  f"come without one")
    if numbers and len(fields) != len(COLUMNS):
        raise RecordingUsageError(f"{path} has no header line and {len(fields)} columns, not the {len(COLUMNS)} of "
                                  f"NGSIM's original text files")
    if numbers:
        return list(COLUMNS), False
    return [_CANONICAL.get(name.strip().casefold(), name.strip()) for name in first.strip().split(",")], True


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_headers(files: list[Path]) -> None:
    """RecordingUsageError when a file lacks a column of NGSIM's published set (before any work)."""
    for path in files:
        check_columns(_header(path)[0], COLUMNS, path, "NGSIM trajectory")


def read(files: list[Path], options: ReadOptions) -> Recording:
    """The vehicles of an NGSIM recording of `options.site` ("us-101" or "i-80"; where a Location column is present,
    only its rows of the site are read), on a road built with the lanes they use (module docstring)."""
    site = options.site
    parts = [_read_file(path, site) for path in files]
    raw, period_note = _one_period(pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0], options.period,
                                   files[0])
    if len(files) > 1 and raw.duplicated(["Vehicle_ID", "Frame_ID"]).any():
        row = raw[raw.duplicated(["Vehicle_ID", "Frame_ID"])].iloc[0]
        raise RecordingDataError(f"vehicle {row['Vehicle_ID']} appears in frame {row['Frame_ID']} of two of the files; "
                                 f"they overlap in time")
    repeated = raw.duplicated(list(_READ))  # the data.transportation.gov edition repeats some rows word for word
    raw = raw[~repeated].sort_values(["Vehicle_ID", "Frame_ID"], kind="stable", ignore_index=True)
    vehicle_ids = _split_reused_ids(raw)
    x = raw["Local_Y"].to_numpy(float) * FEET_M
    _check_forward(vehicle_ids, raw["Frame_ID"].to_numpy(np.int64), x, files[0])
    lane_id = raw["Lane_ID"].to_numpy(np.int64)
    bad = (lane_id < 1) | (lane_id > HIGHEST_LANE_ID)
    if bad.any():
        row = raw.iloc[int(np.argmax(bad))]
        raise RecordingDataError(f"{files[0]}: lane {row['Lane_ID']} of vehicle {row['Vehicle_ID']} at frame "
                                 f"{row['Frame_ID']} is not an NGSIM lane (1 to {HIGHEST_LANE_ID})")
    y = -raw["Local_X"].to_numpy(float) * FEET_M
    dx, dy = _slopes(vehicle_ids, x), _slopes(vehicle_ids, y)
    tracks = pd.DataFrame({
        "vehicle_id": vehicle_ids, "source_id": vehicle_ids, "frame": raw["Frame_ID"].to_numpy(np.int64),
        "time_s": (raw["Frame_ID"].to_numpy(float) - 1.0) / FRAME_RATE_HZ, "x_m": x, "y_m": y,
        "heading_deg": heading_deg(np.where(np.hypot(dx, dy) > 0, dx, 1.0), dy),
        "speed_mps": raw["v_Vel"].to_numpy(float) * FEET_M, "acceleration_mps2": raw["v_Acc"].to_numpy(float) * FEET_M,
        "length_m": (raw["v_Length"].to_numpy(float) * FEET_M).astype(np.float32),
        "width_m": (raw["v_Width"].to_numpy(float) * FEET_M).astype(np.float32),
        "vehicle_class": np.where(raw["v_Class"].to_numpy(np.int64) == TRUCK_CLASS, "truck", "passenger")})
    check_limits(tracks, files[0], "v_Vel", "v_Length")
    length_m = road_length_m(tracks, files[0])
    through, widths, ramp_lane_m = _road(site, lane_id, x, length_m)
    with tempfile.TemporaryDirectory() as scratch:
        net = Path(scratch) / "road.net.xml"
        build_road(list(widths), length_m, net, ramp_lane_m=ramp_lane_m)
        edge, lane, position = place_on_road(net, x, np.minimum(lane_id, through + 1))
    assert (lane >= 0).all()  # the ramp lane reaches past every ramp front (`_road`)
    tracks.insert(tracks.columns.get_loc("length_m"), "edge", edge)
    tracks.insert(tracks.columns.get_loc("length_m"), "lane", lane.astype(np.int16))
    tracks.insert(tracks.columns.get_loc("length_m"), "lane_position_m", position)
    ramps = "a ramp lane right of them" if len(widths) > through or ramp_lane_m else "no ramp"
    notes = [f"NGSIM site {site}: lanes 1 to {through} along the whole section, {ramps}; every track kept",
             *([f"{int(repeated.sum())} row(s) repeated word for word left out"] if repeated.any() else []),
             *([period_note] if period_note else [])]
    return Recording(tracks, FRAME_RATE_HZ, len(widths) + (ramp_lane_m is not None), widths, length_m, notes,
                     tuple(files), ramp_lane_m=ramp_lane_m)


def _road(site: str, lane_id: np.ndarray, x_m: np.ndarray, length_m: float
          ) -> tuple[int, tuple[float, ...], tuple[float, float] | None]:
    """The through lanes of `site`, the lane widths of the road to build [m] (rightmost first) and its ramp lane's
    ends [m] (None: no ramp lane, or one along the whole section, then among the widths)."""
    through = THROUGH_LANES[site]
    on, off = lane_id == ON_RAMP_ID, lane_id == OFF_RAMP_ID
    if not (on.any() or off.any()):
        return through, (LANE_WIDTH_M,) * through, None
    on_m = float(x_m[on].max()) + RAMP_MARGIN_M if on.any() else 0.0
    off_m = float(x_m[off].min()) - RAMP_MARGIN_M if off.any() else length_m
    if off_m - on_m < MIN_THROUGH_M:
        return through, (LANE_WIDTH_M,) * (through + 1), None
    return through, (LANE_WIDTH_M,) * through, (on_m, off_m)


def _read_file(path: Path, site: str) -> pd.DataFrame:
    names, has_header = _header(path)
    wanted = [*_READ, "Location"] if "Location" in names else list(_READ)
    if has_header:
        raw = read_csv(path, "NGSIM trajectory", usecols=lambda name: _CANONICAL.get(name.strip().casefold()) in wanted,
                       low_memory=False)
        raw = raw.rename(columns=lambda name: _CANONICAL[name.strip().casefold()])
    else:
        raw = read_csv(path, "NGSIM trajectory", sep=r"\s+", header=None, names=list(COLUMNS), usecols=list(_READ))
    check_numbers(raw, _READ, path, "Vehicle_ID", "Frame_ID")
    check_positions(raw, ("Local_X", "Local_Y"), path, "Vehicle_ID", "Frame_ID", FEET_M)
    if "Location" in raw:
        here = raw["Location"].astype(str).str.lower().to_numpy() == site
        if not here.any():
            locations = ", ".join(sorted(set(raw["Location"].astype(str).str.lower())))
            raise RecordingDataError(f"{path} has no rows of {site} (its locations: {locations}); pass --site")
        raw = raw[here].drop(columns="Location").reset_index(drop=True)
    return raw


def _one_period(raw: pd.DataFrame, period: int | None, path: Path) -> tuple[pd.DataFrame, str | None]:
    """The rows of recording period `period` (1: the earliest; None: the only one) and a note naming it when the rows
    hold several; RecordingDataError when they hold several and none is chosen, or fewer than `period`."""
    offset_s = (raw["Global_Time"].to_numpy(np.float64) - 100.0 * raw["Frame_ID"].to_numpy(np.float64)) / 1000.0
    offsets = np.unique(offset_s)
    labels = np.cumsum(np.concatenate([[0], np.diff(offsets) > PERIOD_GAP_S]))[np.searchsorted(offsets, offset_s)]
    count = int(labels.max()) + 1
    starts = [_clock(raw["Global_Time"].to_numpy()[labels == label].min()) for label in range(count)]
    if period is None and count > 1:
        raise RecordingDataError(f"{path} holds {count} recording periods (starting {', '.join(starts)}); import one "
                                 f"at a time with --period 1 to {count}")
    if period is not None and period > count:
        raise RecordingDataError(f"--period {period}: {path} holds {count} recording period(s)")
    if count == 1:
        return raw, None
    chosen = (period or 1) - 1
    return (raw[labels == chosen].reset_index(drop=True),
            f"recording period {chosen + 1} of {count}, starting {starts[chosen]}")


def _clock(global_time_ms: float) -> str:
    """An NGSIM Global_Time [ms since 1970] as UTC clock time."""
    return datetime.fromtimestamp(global_time_ms / 1000.0, tz=UTC).strftime("%Y-%m-%d %H:%M:%S UTC")


def _split_reused_ids(raw: pd.DataFrame) -> np.ndarray:
    """Each row's track id: the Vehicle_ID, with "#k" from the k-th vehicle that reused it (rows sorted by id and
    frame)."""
    same = np.concatenate([[False], raw["Vehicle_ID"].to_numpy()[1:] == raw["Vehicle_ID"].to_numpy()[:-1]])
    changed = np.zeros(len(raw), dtype=bool)
    for column in _IDENTITY:
        values = raw[column].to_numpy()
        changed[1:] |= values[1:] != values[:-1]
    new_vehicle = same & changed
    reuse = pd.Series(new_vehicle).groupby(raw["Vehicle_ID"].to_numpy()).cumsum().to_numpy()
    base = raw["Vehicle_ID"].astype(np.int64).astype(str).to_numpy()
    return np.where(reuse > 0, np.char.add(np.char.add(base, "#"), (reuse + 1).astype(str)), base)


def _check_forward(track: np.ndarray, frame: np.ndarray, x: np.ndarray, path: Path) -> None:
    """RecordingDataError naming the first track whose front `x` [m] falls more than BACKWARD_TOLERANCE_M behind the
    farthest it reached over consecutive frames (rows sorted by track and frame; a gap starts afresh)."""
    start = np.concatenate([[True], (track[1:] != track[:-1]) | (np.diff(frame) != 1)])
    back = pd.Series(x).groupby(np.cumsum(start)).cummax().to_numpy() - x
    behind = back > BACKWARD_TOLERANCE_M
    if behind.any():
        first = int(np.argmax(behind))
        raise RecordingDataError(f"{path}: vehicle {track[first]} runs backwards: by frame {frame[first]} its Local_Y "
                                 f"has fallen {back[first] / FEET_M:.1f} ft behind where it was (NGSIM's vehicles "
                                 f"drive toward growing Local_Y as their frames count on)")


def _slopes(track: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Per-frame change of `values` within each track (central differences, one-sided at a track's ends)."""
    ahead = np.concatenate([values[1:], values[-1:]])
    behind = np.concatenate([values[:1], values[:-1]])
    next_same = np.concatenate([track[1:] == track[:-1], [False]])
    previous_same = np.concatenate([[False], track[1:] == track[:-1]])
    return np.where(next_same, ahead, values) - np.where(previous_same, behind, values)


def write(tracks: pd.DataFrame, lanes: int, path: Path) -> Path:
    """Write `tracks` (a scene on a straight road along +x whose left edge is y = 0, `lanes` lanes) as an NGSIM
    trajectory CSV at 10 Hz in feet; Global_X / Global_Y repeat Local_X / Local_Y (no survey coordinates)."""
    rows = resampled(tracks, FRAME_RATE_HZ)
    numbers = {vehicle: index + 1 for index, vehicle in enumerate(sorted(rows["vehicle_id"].unique()))}
    ids = rows["vehicle_id"].map(numbers).to_numpy(np.int64)
    frames = rows["frame"].to_numpy(np.int64) + 1
    front, lane = rows["x_m"].to_numpy(float), rows["lane"].to_numpy(np.int64)
    speed, length = rows["speed_mps"].to_numpy(float), rows["length_m"].to_numpy(float)
    near = neighbours(frames, lane, front, length)
    distance, time, _ = headways(front, speed, length, near.preceding)
    local_x, local_y = -rows["y_m"].to_numpy(float) / FEET_M, front / FEET_M
    out = pd.DataFrame({
        "Vehicle_ID": ids, "Frame_ID": frames, "Total_Frames": pd.Series(ids).map(pd.Series(ids).value_counts()),
        "Global_Time": frames * 100, "Local_X": local_x, "Local_Y": local_y, "Global_X": local_x,
        "Global_Y": local_y, "v_Length": length / FEET_M, "v_Width": rows["width_m"].to_numpy(float) / FEET_M,
        "v_Class": np.where(rows["vehicle_class"] == "truck", TRUCK_CLASS, 2), "v_Vel": speed / FEET_M,
        "v_Acc": rows["acceleration_mps2"].to_numpy(float) / FEET_M, "Lane_ID": lanes - lane,
        "Preceding": np.where(near.preceding == NO_VEHICLE, 0, ids[np.maximum(near.preceding, 0)]),
        "Following": np.where(near.following == NO_VEHICLE, 0, ids[np.maximum(near.following, 0)]),
        "Space_Headway": distance / FEET_M, "Time_Headway": np.where(time > 0, time, 9999.99)})
    out.to_csv(path, index=False, float_format="%.3f")
    return path
