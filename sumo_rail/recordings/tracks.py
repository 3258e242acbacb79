"""What every reader shares: its errors, the checks of a recording's values and the tracks it keeps or drops.

A reader (`formats.FormatReader`) turns its files into rows of `scene.TRACK_COLUMNS` plus `frame` (the recording's
frame number), a `Recording`, whose tracks `kept_tracks` then keeps or drops whole, each with its reason
(`DROP_REASONS`), refusing what no recording of the format can hold (a vehicle twice in one frame, NaNs, impossible
values) in one sentence.
"""

from __future__ import annotations

import gzip
import math
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.datasets import DatasetError, describe

MAX_SPEED_MPS = 100.0
"""A speed above this [m/s] (360 km/h) is a broken recording, not driving; below 0 is one too."""
MAX_LENGTH_M = 30.0
"""A vehicle longer than this [m] is a broken recording (a long road train is 25.25 m)."""
MAX_ROAD_M = 100_000.0
"""The longest road a recording may span [m] (100 km; highD's sections are about 420 m, NGSIM's 500-640 m): a
position farther than this from the recording's origin, or a built road longer than this, is a broken recording."""
LANE_TOLERANCE_M = 1.0
"""A vehicle's centre this far [m] beyond the sides of the lane a recording names is on another lane (or road)."""
GAP, TOO_SHORT = "gap in frames", "too short for one decision"
DROP_REASONS = (GAP, TOO_SHORT)
"""Why a track is left out of a scene, in one phrase each; a track with several is left out for the first."""


class RecordingUsageError(DatasetError):
    """A recording found unusable before any work: missing, of another format, missing or renamed columns (exit 2)."""


class RecordingDataError(DatasetError):
    """A recording whose data are broken, found while reading it (exit 1)."""


@dataclass
class Recording:
    """What a reader read: the tracks (`TRACK_COLUMNS`, `frame`, `source_id`) and what the scene needs to know."""

    tracks: pd.DataFrame
    frame_rate_hz: float
    lanes: int
    lane_widths_m: tuple[float, ...] = ()
    """The road to build, rightmost lane first [m]; empty for FCD (the user's network)."""
    road_length_m: float = 0.0
    """Length of the road to build [m]."""
    notes: list[str] = field(default_factory=list)
    """What the reader left out of the recording, one sentence each (the other driving direction, ramps)."""
    sources: tuple[Path, ...] = ()
    """Every file read: the files given and any companion the format reads beside them (highD's meta files)."""
    opposite_lane_widths_m: tuple[float, ...] = ()
    """The other carriageway of the road to build, rightmost lane first [m], driven toward -x with its left edge
    `median_m` above y = 0 (a scene of both driving directions); empty: none."""
    median_m: float = 0.0
    """The strip between the carriageways [m]."""
    ramp_lane_m: tuple[float, float] | None = None
    """A ramp lane right of the road to build: an on-ramp from x = 0 to the first [m], an off-ramp from the second
    to the end (`road.build_road`); None: none."""


def check_columns(found: list[str], expected: tuple[str, ...], path: object, what: str) -> None:
    """RecordingUsageError naming the first of `expected` columns missing from the header `found` of `path`."""
    missing = [column for column in expected if column not in found]
    if missing:
        shown = ", ".join(printable(name) for name in found[:6])
        raise RecordingUsageError(f"{path} is not a {what} file: it lacks the column {missing[0]!r} "
                                  f"(found {shown}{', ...' if len(found) > 6 else ''})")


def printable(text: str) -> str:
    """`text` with every character a terminal would not print as itself replaced by "?"."""
    return "".join(char if char.isprintable() else "?" for char in text)


def text_head(path: Path) -> tuple[str, str | None]:
    """The first line of the CSV or text file `path` (UTF-8, a byte-order mark dropped; a gzip-compressed file read
    as such, whatever its name) and the compression pandas must read it with ("gzip" or None);
    RecordingUsageError when it is not text."""
    with open(path, "rb") as file:
        compression = "gzip" if file.read(2) == b"\x1f\x8b" else None
    try:
        with (gzip.open(path, "rt", encoding="utf-8-sig", newline="") if compression
              else open(path, encoding="utf-8-sig", newline="")) as file:
            line = file.readline(1 << 16)
    except (UnicodeDecodeError, OSError, EOFError, zlib.error):
        line = "\x00"
    if any(not (char.isprintable() or char in "\t\r\n") for char in line):
        raise RecordingUsageError(f"{path} is not a text file: it holds binary bytes (a gzip-compressed file is read "
                                  f"as such; unpack other archives first)")
    return line, compression


def read_csv(path: Path, what: str, **options: Any) -> pd.DataFrame:
    """`pd.read_csv` of `path` (UTF-8, a byte-order mark dropped, gzip-compressed as `text_head` finds);
    RecordingDataError naming the file when pandas cannot read it as a `what` file."""
    try:
        return pd.read_csv(path, encoding="utf-8-sig", compression=text_head(path)[1], **options)
    except (ValueError, OSError, EOFError, zlib.error) as error:  # pandas' parser errors are ValueErrors
        raise RecordingDataError(f"{path} is not a readable {what} file: {printable(describe(error))}") from error


def check_numbers(table: pd.DataFrame, columns: tuple[str, ...], path: object, id_column: str,
                  frame_column: str) -> None:
    """RecordingDataError naming the column, vehicle and frame of the first value of `columns` that is not a number
    (its data row, counted from 1, where the row has no vehicle id or frame either)."""
    for column in columns:
        values = pd.to_numeric(table[column], errors="coerce")
        bad = values.isna().to_numpy()
        if bad.any():
            first = int(np.argmax(bad))
            vehicle, frame = (table[name].iat[first] for name in (id_column, frame_column))
            named = pd.notna(pd.to_numeric(pd.Series([vehicle, frame]), errors="coerce")).all()
            where = (f"of vehicle {plain(vehicle)} at frame {plain(frame)}" if named
                     else f"in data row {first + 1} (a row without a vehicle id or frame)")
            raise RecordingDataError(f"{path}: column {column} {where} is missing or not a number")
        if values.dtype != table[column].dtype:
            table[column] = values


def plain(value: object) -> object:
    """A number as a user wrote it, for messages: 4.0 -> 4."""
    return int(value) if isinstance(value, float) and value.is_integer() else value


def at(row: pd.Series, by_time: bool) -> str:
    """Where in the recording a row of scene tracks is, for messages: its frame, or its time [s] (`by_time`)."""
    return f"at {row['time_s']:g} s" if by_time else f"at frame {row['frame']}"


def check_limits(tracks: pd.DataFrame, path: object, speed_column: str, length_column: str,
                 by_time: bool = False) -> None:
    """RecordingDataError naming the vehicle (and its frame, or time with `by_time`) whose speed lies outside
    [0, MAX_SPEED_MPS] or length outside (0, MAX_LENGTH_M] (the source's columns named)."""
    for values, column, unit, low, high in ((tracks["speed_mps"], speed_column, "m/s", "[0", f"{MAX_SPEED_MPS:g}]"),
                                            (tracks["length_m"], length_column, "m", "(0", f"{MAX_LENGTH_M:g}]")):
        number = values.to_numpy()
        limit = MAX_SPEED_MPS if column == speed_column else MAX_LENGTH_M
        outside = (number > limit) | ((number < 0) if column == speed_column else (number <= 0))
        if outside.any():
            first = int(np.argmax(outside))
            row = tracks.iloc[first]
            raise RecordingDataError(f"{path}: vehicle {row['source_id']} has {column} {number[first]:.1f} {unit} "
                                     f"{at(row, by_time)}, outside {low}, {high} {unit}")


def check_positions(table: pd.DataFrame, columns: tuple[str, ...], path: object, id_column: str, frame_column: str,
                    metres_per_unit: float = 1.0) -> None:
    """RecordingDataError naming the column, vehicle and frame of the first position in `columns` (in units of
    `metres_per_unit` [m]) that is not finite or lies farther than MAX_ROAD_M from the recording's origin."""
    for column in columns:
        metres = table[column].to_numpy(float) * metres_per_unit
        bad = ~(np.abs(metres) <= MAX_ROAD_M)
        if bad.any():
            first = int(np.argmax(bad))
            raise RecordingDataError(f"{path}: column {column} of vehicle {plain(table[id_column].iat[first])} at "
                                     f"frame {plain(table[frame_column].iat[first])} is {table[column].iat[first]:g}, "
                                     f"not a position within {MAX_ROAD_M / 1000:g} km of the recording's origin (the "
                                     f"longest road a recording may span)")


def road_length_m(tracks: pd.DataFrame, path: object) -> float:
    """The length [m] of the straight road a highD or NGSIM recording's tracks need: the farthest front bumper plus
    twice the longest vehicle; RecordingDataError naming the farthest vehicle when it exceeds MAX_ROAD_M."""
    front = tracks["x_m"].to_numpy(float)
    length_m = float(np.max(front, initial=0.0)) + 2 * float(np.max(tracks["length_m"].to_numpy(), initial=0.0))
    if length_m > MAX_ROAD_M:
        row = tracks.iloc[int(np.argmax(front))]
        raise RecordingDataError(f"{path}: vehicle {row['source_id']} at frame {row['frame']} is {row['x_m']:.0f} m "
                                 f"along the road, which would be longer than {MAX_ROAD_M / 1000:g} km (the longest "
                                 f"road a recording may span)")
    return length_m


def heading_deg(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """SUMO's angle [deg] (0 = north, clockwise) of the direction (dx, dy) in network coordinates."""
    return np.mod(90.0 - np.degrees(np.arctan2(dy, dx)), 360.0)


def decision_frames(frame_rate_hz: float, decision_period_s: float) -> int:
    """Frames a track needs for one decision: the frames of one decision period and the one after it."""
    return math.ceil(decision_period_s * frame_rate_hz - 1e-9) + 1


def kept_tracks(tracks: pd.DataFrame, frame_rate_hz: float, decision_period_s: float, path: object,
                gaps_fail: bool) -> tuple[pd.DataFrame, dict[str, str]]:
    """The tracks worth keeping, sorted by vehicle and time, and each dropped track's `source_id` -> reason: a gap in
    its frames (`gaps_fail`: a RecordingDataError instead, for formats whose tracks
    are contiguous by definition), fewer frames than one decision needs. A vehicle twice in one frame is a
    RecordingDataError."""
    if tracks.empty:
        raise RecordingDataError(f"{path} holds no vehicle; the recording is empty")
    tracks = tracks.sort_values(["vehicle_id", "frame"], kind="stable", ignore_index=True)
    same = tracks["vehicle_id"].to_numpy()[1:] == tracks["vehicle_id"].to_numpy()[:-1]
    step = np.diff(tracks["frame"].to_numpy())
    twice = same & (step == 0)
    if twice.any():
        row = tracks.iloc[int(np.argmax(twice))]
        raise RecordingDataError(f"{path}: vehicle {row['source_id']} appears twice in frame {row['frame']}")
    gap = np.concatenate([[False], same & (step > 1)])
    if gaps_fail and gap.any():
        row = tracks.iloc[int(np.argmax(gap))]
        raise RecordingDataError(f"{path}: vehicle {row['source_id']} has a gap in its frames before frame "
                                 f"{row['frame']}")
    by_vehicle = pd.DataFrame({"vehicle_id": tracks["vehicle_id"], "gap": gap}).groupby("vehicle_id", sort=True)
    summary = by_vehicle.agg(gap=("gap", "any"), frames=("gap", "size"))
    failed = {GAP: summary["gap"],
              TOO_SHORT: summary["frames"] < decision_frames(frame_rate_hz, decision_period_s)}
    reasons = pd.Series("", index=summary.index)
    for reason in reversed(DROP_REASONS):  # the first of DROP_REASONS a track fails is written last
        reasons[failed[reason]] = reason
    dropped_ids = reasons[reasons != ""]
    source = tracks.drop_duplicates("vehicle_id").set_index("vehicle_id")["source_id"]
    dropped = {str(source[vehicle]): reason for vehicle, reason in dropped_ids.items()}
    kept = tracks[~tracks["vehicle_id"].isin(dropped_ids.index)].reset_index(drop=True)
    return kept, dropped
