"""What every reader shares: its errors, the checks of a recording's values and the tracks it keeps or drops.

A reader turns its files into rows of `scene.TRACK_COLUMNS` plus `frame` (the recording's frame number) and hands
them to `kept_tracks`, which drops whole tracks, each with its reason (`DROP_REASONS`), and refuses what no
recording of the format can hold (a vehicle twice in one frame, NaNs, impossible values) in one sentence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import pyarrow as pa

from sumo_rail.datasets import DatasetError
from sumo_rail.recordings.scene import TRACK_COLUMNS, TRACK_SCHEMA

MAX_SPEED_MPS = 100.0
"""A speed above this [m/s] (360 km/h) is a broken recording, not driving."""
MAX_LENGTH_M = 30.0
"""A vehicle longer than this [m] is a broken recording (a long road train is 25.25 m)."""
TOO_SHORT, OFF_LANES, GAP = "too short for one decision", "off the modelled lanes", "gap in frames"
DROP_REASONS = (TOO_SHORT, OFF_LANES, GAP)
"""Why a track is left out of a scene, in one phrase each."""
OFF_ROAD_LANE = -1
"""The `lane` a reader gives a row outside the modelled lanes (a ramp, the other driving direction's lanes)."""


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


def check_columns(found: list[str], expected: tuple[str, ...], path: object, what: str) -> None:
    """RecordingUsageError naming the first of `expected` columns missing from the header `found` of `path`."""
    missing = [column for column in expected if column not in found]
    if missing:
        raise RecordingUsageError(f"{path} is not a {what} file: it lacks the column {missing[0]!r} "
                                  f"(found {', '.join(found[:6])}{', ...' if len(found) > 6 else ''})")


def check_numbers(table: pd.DataFrame, columns: tuple[str, ...], path: object, id_column: str,
                  frame_column: str) -> None:
    """RecordingDataError naming the column, vehicle and frame of the first value of `columns` that is not a number."""
    for column in columns:
        values = pd.to_numeric(table[column], errors="coerce")
        bad = values.isna().to_numpy()
        if bad.any():
            first = int(np.argmax(bad))
            raise RecordingDataError(f"{path}: column {column} of vehicle {plain(table[id_column].iat[first])} at "
                                     f"frame {plain(table[frame_column].iat[first])} is missing or not a number")
        if values.dtype != table[column].dtype:
            table[column] = values


def plain(value: object) -> object:
    """A number as a user wrote it, for messages: 4.0 -> 4."""
    return int(value) if isinstance(value, float) and value.is_integer() else value


def check_limits(tracks: pd.DataFrame, path: object, speed_column: str, length_column: str) -> None:
    """RecordingDataError naming the vehicle whose speed exceeds MAX_SPEED_MPS or length exceeds MAX_LENGTH_M (the
    source's columns named)."""
    for values, limit, column, unit in ((tracks["speed_mps"], MAX_SPEED_MPS, speed_column, "m/s"),
                                        (tracks["length_m"], MAX_LENGTH_M, length_column, "m")):
        over = (values.to_numpy() > limit) | (values.to_numpy() <= 0 if column == length_column else False)
        if over.any():
            first = int(np.argmax(over))
            row = tracks.iloc[first]
            raise RecordingDataError(f"{path}: vehicle {row['source_id']} has {column} {values.iloc[first]:.1f} {unit} "
                                     f"at frame {row['frame']}, outside (0, {limit:g}] {unit}")


def heading_deg(dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """SUMO's angle [deg] (0 = north, clockwise) of the direction (dx, dy) in network coordinates."""
    return np.mod(90.0 - np.degrees(np.arctan2(dy, dx)), 360.0)


def decision_frames(frame_rate_hz: float, decision_period_s: float) -> int:
    """Frames a track needs for one decision: the frames of one decision period and the one after it."""
    return math.ceil(decision_period_s * frame_rate_hz - 1e-9) + 1


def kept_tracks(tracks: pd.DataFrame, frame_rate_hz: float, decision_period_s: float, path: object,
                gaps_fail: bool) -> tuple[pd.DataFrame, dict[str, str]]:
    """The tracks worth keeping, sorted by vehicle and time, and each dropped track's `source_id` -> reason: a row
    off the modelled lanes, a gap in its frames (`gaps_fail`: a RecordingDataError instead, for formats whose tracks
    are contiguous by definition), fewer frames than one decision needs. A vehicle twice in one frame is a
    RecordingDataError."""
    if tracks.empty:
        raise RecordingDataError(f"{path} holds no vehicle in the modelled lanes; the recording is empty")
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
    by_vehicle = pd.DataFrame({"vehicle_id": tracks["vehicle_id"], "gap": gap,
                               "off": tracks["lane"].to_numpy() == OFF_ROAD_LANE}).groupby("vehicle_id", sort=True)
    summary = by_vehicle.agg(gap=("gap", "any"), off=("off", "any"), frames=("gap", "size"))
    reasons = pd.Series("", index=summary.index)
    reasons[summary["frames"] < decision_frames(frame_rate_hz, decision_period_s)] = TOO_SHORT
    reasons[summary["gap"]] = GAP
    reasons[summary["off"]] = OFF_LANES
    dropped_ids = reasons[reasons != ""]
    source = tracks.drop_duplicates("vehicle_id").set_index("vehicle_id")["source_id"]
    dropped = {str(source[vehicle]): reason for vehicle, reason in dropped_ids.items()}
    kept = tracks[~tracks["vehicle_id"].isin(dropped_ids.index)].reset_index(drop=True)
    return kept, dropped


def track_table(tracks: pd.DataFrame) -> pa.Table:
    """The kept tracks as a table of `TRACK_SCHEMA`."""
    return pa.Table.from_pandas(tracks[list(TRACK_COLUMNS)], schema=TRACK_SCHEMA, preserve_index=False)
