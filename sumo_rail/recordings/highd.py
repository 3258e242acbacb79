"""highD recordings (https://www.highd-dataset.com): read one driving direction into a scene, and write a scene out.

A recording is three CSV files, XX_tracks.csv (one row per vehicle per frame), XX_tracksMeta.csv (one per vehicle)
and XX_recordingMeta.csv (one row: frameRate, upperLaneMarkings, lowerLaneMarkings ...). Positions are image
coordinates in metres, x to the right and y down; (x, y) is the top-left corner of the vehicle's bounding box,
`width` its extent along x (the length) and `height` along y (the width). drivingDirection 1 is the upper carriageway,
driven leftwards (its rightmost lane at the top), 2 the lower one, driven rightwards (its rightmost lane at the
bottom). laneId counts the strips between markings from the top, from 1: a recording with n lanes a direction has
upper lanes 2 .. n + 1 and lower lanes n + 3 .. 2n + 2.

One direction is read at a time, the other left out (said so in the scene's notes): the scene's road is a straight
edge along +x in the driving direction whose lanes have the widths between the direction's markings; its x is the
image x of the front bumper (lower) or the image's right end minus it (upper). Or both at once (direction "both"): the
road is then both carriageways, the lower one as above (edge `road.ROAD_EDGE` along +x, left edge at y = 0) and the
upper one where the image has it (edge `road.OPPOSITE_EDGE`, driven toward -x, its left edge the median's width above
y = 0), x the image x shifted as the lower direction's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.levelx import SUFFIXES, LevelXLayout
from sumo_rail.recordings.road import OPPOSITE_EDGE, ROAD_EDGE
from sumo_rail.recordings.tracks import (
    LANE_TOLERANCE_M,
    Recording,
    RecordingDataError,
    check_limits,
    check_numbers,
    check_positions,
    heading_deg,
    plain,
    read_csv,
    road_length_m,
)
from sumo_rail.recordings.writing import NO_VEHICLE, headways, neighbours, resampled

TRACKS_COLUMNS = ("frame", "id", "x", "y", "width", "height", "xVelocity", "yVelocity", "xAcceleration",
                  "yAcceleration", "frontSightDistance", "backSightDistance", "dhw", "thw", "ttc",
                  "precedingXVelocity", "precedingId", "followingId", "leftPrecedingId", "leftAlongsideId",
                  "leftFollowingId", "rightPrecedingId", "rightAlongsideId", "rightFollowingId", "laneId")
TRACKS_META_COLUMNS = ("id", "width", "height", "initialFrame", "finalFrame", "numFrames", "class",
                       "drivingDirection", "traveledDistance", "minXVelocity", "maxXVelocity", "meanXVelocity",
                       "minDHW", "minTHW", "minTTC", "numLaneChanges")
RECORDING_META_COLUMNS = ("id", "frameRate", "locationId", "speedLimit", "month", "weekDay", "startTime", "duration",
                          "totalDrivenDistance", "totalDrivenTime", "numVehicles", "numCars", "numTrucks",
                          "upperLaneMarkings", "lowerLaneMarkings")
DIRECTIONS = {"upper": 1, "lower": 2}
"""--direction -> highD's drivingDirection."""
FRAME_RATE_HZ = 25.0
MEDIAN_M = 1.0
"""The strip between the carriageways a written recording has [m]."""
_READ = ("frame", "id", "x", "y", "width", "height", "xVelocity", "yVelocity", "xAcceleration", "yAcceleration",
         "laneId")


LAYOUT = LevelXLayout("highD", TRACKS_COLUMNS, TRACKS_META_COLUMNS, RECORDING_META_COLUMNS)
"""highD's three files and their columns."""
check_headers = LAYOUT.check_headers
"""RecordingUsageError when a file lacks a column of highD's published set (before any work)."""


def _markings(meta: pd.Series, column: str, path: Path) -> np.ndarray:
    try:
        values = np.array([float(value) for value in str(meta[column]).split(";")])
    except ValueError as error:
        raise RecordingDataError(f"{path}: {column} {meta[column]!r} is not a list of y values separated by ';'"
                                 ) from error
    if len(values) < 2 or np.any(np.diff(values) <= 0) or not np.all(np.isfinite(values)):
        raise RecordingDataError(f"{path}: {column} must be at least two increasing y values, got {meta[column]!r}")
    return values


def read(files: list[Path], options: ReadOptions) -> Recording:
    """The vehicles of one driving direction (`options.direction`, "upper" or "lower") of a highD recording, or of
    both ("both")."""
    direction = options.direction
    sources = LAYOUT.recording_files(files)
    tracks_path, tracks_meta_path, recording_meta_path = sources
    recording = read_csv(recording_meta_path, "highD recordingMeta")
    if recording.empty:
        raise RecordingDataError(f"{recording_meta_path} has no row")
    meta_row = recording.iloc[0]
    upper = _markings(meta_row, "upperLaneMarkings", recording_meta_path)
    lower = _markings(meta_row, "lowerLaneMarkings", recording_meta_path)
    rate = LAYOUT.frame_rate_hz(recording, recording_meta_path)
    meta = read_csv(tracks_meta_path, "highD tracksMeta", usecols=["id", "class", "drivingDirection"])
    check_numbers(meta, ("id", "drivingDirection"), tracks_meta_path, "id", "drivingDirection")
    reused = meta["id"].duplicated()
    if reused.any():
        raise RecordingDataError(f"{tracks_meta_path}: vehicle id {meta['id'][reused].iloc[0]} is used twice; "
                                 f"highD ids are unique")
    raw = read_csv(tracks_path, "highD tracks", usecols=list(_READ), dtype={"laneId": "Int64"}, engine="c")
    check_numbers(raw, _READ, tracks_path, "id", "frame")
    check_positions(raw, ("x", "y"), tracks_path, "id", "frame")
    known = raw["id"].isin(meta["id"])
    if not known.all():
        raise RecordingDataError(f"{tracks_path}: vehicle {raw['id'][~known].iloc[0]} is not in "
                                 f"{tracks_meta_path.name}")
    sides = ("lower", "upper") if direction == "both" else (direction,)
    shift_m = min(0.0, float(np.min(raw["x"].to_numpy(float), initial=0.0))) if direction == "both" else None
    parts = []
    for side in sides:
        wanted = meta.loc[meta["drivingDirection"] == DIRECTIONS[side]]
        rows = raw[raw["id"].isin(wanted["id"])].reset_index(drop=True)
        classes = wanted.set_index("id")["class"].reindex(rows["id"]).to_numpy()
        part = _scene_rows(rows, side, upper, lower, rate, tracks_path, shift_m)
        part["vehicle_class"] = np.where(np.isin(np.char.lower(classes.astype(str)), ["truck", "bus"]), "truck",
                                         "passenger")
        parts.append(part)
    tracks = pd.concat(parts, ignore_index=True) if len(parts) > 1 else parts[0]
    check_limits(tracks, tracks_path, "xVelocity", "width")
    length_m = road_length_m(tracks, tracks_path)
    if direction == "both":
        opposite = (tracks["edge"] == OPPOSITE_EDGE).to_numpy()
        tracks.loc[opposite, "lane_position_m"] = length_m - tracks.loc[opposite, "x_m"]
        return Recording(tracks, rate, len(lower) - 1, tuple(float(width) for width in np.diff(lower)[::-1]),
                         length_m, [], sources, tuple(float(width) for width in np.diff(upper)),
                         float(lower[0] - upper[-1]))  # the median: from the upper's last marking to the lower's first
    markings = upper if direction == "upper" else lower
    widths = np.diff(markings) if direction == "upper" else np.diff(markings)[::-1]
    other = "lower" if direction == "upper" else "upper"
    wanted = meta.loc[meta["drivingDirection"] == DIRECTIONS[direction]]
    notes = [f"the {other} driving direction ({len(meta) - len(wanted)} vehicles) is left out; import it with "
             f"--direction {other}, or both with --direction both"]
    return Recording(tracks, rate, len(widths), tuple(float(width) for width in widths), length_m, notes, sources)


def _scene_rows(raw: pd.DataFrame, direction: str, upper: np.ndarray, lower: np.ndarray, rate: float,
                path: Path, shift_m: float | None = None) -> pd.DataFrame:
    """highD rows in the scene's coordinates: the front bumper's centre on a road along +x whose left edge is y = 0;
    with `shift_m` (a scene of both directions), every image x less `shift_m` [m] and the upper direction where the
    image has it, on `OPPOSITE_EDGE` (its lane positions are the caller's: they count from the road's far end)."""
    x, y = raw["x"].to_numpy(float), raw["y"].to_numpy(float)
    length, width = raw["width"].to_numpy(float), raw["height"].to_numpy(float)
    vx, vy = raw["xVelocity"].to_numpy(float), raw["yVelocity"].to_numpy(float)
    ax, ay = raw["xAcceleration"].to_numpy(float), raw["yAcceleration"].to_numpy(float)
    centre_y = y + width / 2
    if direction == "upper" and shift_m is None:
        end = float(np.max(x + length, initial=0.0))
        front, lateral, dx, dy, forward = end - x, centre_y - upper[-1], -vx, vy, -1.0
        markings, first_lane = upper, 2
    elif direction == "upper":
        front, lateral, dx, dy, forward = x - shift_m, lower[0] - centre_y, vx, -vy, -1.0
        markings, first_lane = upper, 2
    else:
        shift = min(0.0, float(np.min(x, initial=0.0))) if shift_m is None else shift_m
        front, lateral, dx, dy, forward = x + length - shift, lower[0] - centre_y, vx, -vy, 1.0
        markings, first_lane = lower, len(upper) + 2
    lanes = len(markings) - 1
    strip = raw["laneId"].to_numpy(np.int64) - first_lane  # strip between markings, from the top
    outside = (strip < 0) | (strip >= lanes)
    if outside.any():
        row = _first(raw, outside)
        raise RecordingDataError(f"{path}: lane {row['laneId']} of vehicle {row['id']} at frame {row['frame']} is not "
                                 f"a lane of the {direction} direction's markings")
    strip_index = np.clip(strip, 0, lanes - 1)
    off = (centre_y < markings[strip_index] - LANE_TOLERANCE_M) | (centre_y > markings[strip_index + 1]
                                                                   + LANE_TOLERANCE_M)
    if off.any():
        row = _first(raw, off)
        raise RecordingDataError(f"{path}: vehicle {row['id']} at frame {row['frame']} is in lane {row['laneId']} but "
                                 f"its centre y {centre_y[int(np.argmax(off))]:.2f} m lies outside that lane's "
                                 f"markings")
    against = vx * forward < 0
    if against.any():
        row = _first(raw, against)
        toward = "falling" if forward < 0 else "growing"
        raise RecordingDataError(f"{path}: vehicle {row['id']} has xVelocity {row['xVelocity']} m/s at frame "
                                 f"{row['frame']}, against the {direction} direction (drivingDirection "
                                 f"{DIRECTIONS[direction]}), which is driven toward {toward} x")
    speed = np.hypot(vx, vy)
    along = np.where(speed > 0, (ax * vx + ay * vy) / np.maximum(speed, 1e-9), ax * forward)
    lane = strip if direction == "upper" else lanes - 1 - strip
    ids = raw["id"].astype(np.int64).astype(str)
    return pd.DataFrame({
        "vehicle_id": ids, "source_id": ids, "frame": raw["frame"].to_numpy(np.int64),
        "time_s": (raw["frame"].to_numpy(float) - 1.0) / rate, "x_m": front, "y_m": lateral,
        "heading_deg": heading_deg(np.where(speed > 0, dx, 1.0), np.where(speed > 0, dy, 0.0)),
        "speed_mps": speed, "acceleration_mps2": along,
        "edge": OPPOSITE_EDGE if direction == "upper" and shift_m is not None else ROAD_EDGE,
        "lane": lane.astype(np.int16), "lane_position_m": front,
        "length_m": length.astype(np.float32), "width_m": width.astype(np.float32)})


def _first(raw: pd.DataFrame, mask: np.ndarray) -> dict[str, object]:
    """The first row of `raw` where `mask` holds, its numbers as a user wrote them (for messages)."""
    return {key: plain(value) for key, value in raw.iloc[int(np.argmax(mask))].items()}


def write(tracks: pd.DataFrame, lane_widths_m: tuple[float, ...], road_length_m: float, stem: Path) -> list[Path]:
    """Write `tracks` (a scene on a straight road along +x whose left edge is y = 0, lanes of `lane_widths_m`,
    rightmost first) as the lower direction of a highD recording `stem`_tracks.csv, _tracksMeta.csv and
    _recordingMeta.csv at 25 Hz; the upper carriageway gets the same lanes and no vehicle. Returns the paths."""
    rows = resampled(tracks, FRAME_RATE_HZ)
    widths = np.asarray(lane_widths_m, float)
    upper = MEDIAN_M + np.concatenate([[0.0], np.cumsum(widths)])
    lower = upper[-1] + MEDIAN_M + np.concatenate([[0.0], np.cumsum(widths[::-1])])
    heading = np.radians(rows["heading_deg"].to_numpy(float))
    speed, along = rows["speed_mps"].to_numpy(float), rows["acceleration_mps2"].to_numpy(float)
    length, width = rows["length_m"].to_numpy(float), rows["width_m"].to_numpy(float)
    front, lane = rows["x_m"].to_numpy(float), rows["lane"].to_numpy(np.int64)
    numbers = {vehicle: index + 1 for index, vehicle in enumerate(sorted(rows["vehicle_id"].unique()))}
    ids = rows["vehicle_id"].map(numbers).to_numpy(np.int64)
    frames = rows["frame"].to_numpy(np.int64) + 1
    near = neighbours(frames, lane, front, length)
    dhw, thw, ttc = headways(front, speed, length, near.preceding)

    def id_of(index: np.ndarray) -> np.ndarray:
        return np.where(index == NO_VEHICLE, 0, ids[np.maximum(index, 0)])

    vx = speed * np.sin(heading)
    out = pd.DataFrame({
        "frame": frames, "id": ids, "x": front - length, "y": lower[0] - rows["y_m"].to_numpy(float) - width / 2,
        "width": length, "height": width, "xVelocity": vx, "yVelocity": -speed * np.cos(heading),
        "xAcceleration": along * np.sin(heading), "yAcceleration": -along * np.cos(heading),
        "frontSightDistance": road_length_m - front, "backSightDistance": front - length, "dhw": dhw, "thw": thw,
        "ttc": ttc,
        "precedingXVelocity": np.where(near.preceding == NO_VEHICLE, 0.0, vx[np.maximum(near.preceding, 0)]),
        "precedingId": id_of(near.preceding), "followingId": id_of(near.following),
        "leftPrecedingId": id_of(near.left_preceding), "leftAlongsideId": id_of(near.left_alongside),
        "leftFollowingId": id_of(near.left_following), "rightPrecedingId": id_of(near.right_preceding),
        "rightAlongsideId": id_of(near.right_alongside), "rightFollowingId": id_of(near.right_following),
        "laneId": len(upper) + 2 + (len(widths) - 1 - lane)})
    meta = _tracks_meta(out, rows)
    recording = pd.DataFrame([{
        "id": 1, "frameRate": int(FRAME_RATE_HZ), "locationId": 0, "speedLimit": -1, "month": "", "weekDay": "",
        "startTime": "00:00", "duration": float(frames.max(initial=0)) / FRAME_RATE_HZ,
        "totalDrivenDistance": float(meta["traveledDistance"].sum()),
        "totalDrivenTime": float(meta["numFrames"].sum()) / FRAME_RATE_HZ, "numVehicles": len(meta),
        "numCars": int((meta["class"] == "Car").sum()), "numTrucks": int((meta["class"] == "Truck").sum()),
        "upperLaneMarkings": ";".join(f"{value:.2f}" for value in upper),
        "lowerLaneMarkings": ";".join(f"{value:.2f}" for value in lower)}])
    paths = [Path(f"{stem}{suffix}") for suffix in SUFFIXES]
    for table, path in zip((out, meta, recording), paths, strict=True):
        table.to_csv(path, index=False, float_format="%.3f")
    return paths


def _tracks_meta(out: pd.DataFrame, rows: pd.DataFrame) -> pd.DataFrame:
    """One tracksMeta row per vehicle of the written tracks `out` (scene rows `rows`)."""
    table = out.assign(vehicle_class=rows["vehicle_class"].to_numpy(), lane_change=0)
    table["lane_change"] = (table["laneId"].diff().fillna(0) != 0) & (table["id"].diff().fillna(1) == 0)
    by = table.groupby("id", sort=True)
    meta = by.agg(width=("width", "first"), height=("height", "first"), initialFrame=("frame", "min"),
                  finalFrame=("frame", "max"), numFrames=("frame", "size"), minXVelocity=("xVelocity", "min"),
                  maxXVelocity=("xVelocity", "max"), meanXVelocity=("xVelocity", "mean"),
                  numLaneChanges=("lane_change", "sum"), vehicle_class=("vehicle_class", "first"),
                  first_x=("x", "first"), last_x=("x", "last"))
    positive = table[table["dhw"] > 0].groupby("id")
    meta["minDHW"] = positive["dhw"].min().reindex(meta.index).fillna(-1)
    meta["minTHW"] = table[table["thw"] > 0].groupby("id")["thw"].min().reindex(meta.index).fillna(-1)
    meta["minTTC"] = table[table["ttc"] > 0].groupby("id")["ttc"].min().reindex(meta.index).fillna(-1)
    meta["traveledDistance"] = (meta["last_x"] - meta["first_x"]).abs()
    meta["class"] = np.where(meta["vehicle_class"] == "truck", "Truck", "Car")
    meta["drivingDirection"] = DIRECTIONS["lower"]
    return meta.reset_index()[list(TRACKS_META_COLUMNS)]
