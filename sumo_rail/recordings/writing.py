"""What the writers share: a scene's tracks resampled to a format's frame rate, and each vehicle's neighbours (the
nearest vehicle ahead and behind in its lane and in the lanes beside it) that highD and NGSIM files carry."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from sumo_rail.recordings.scene import TRACK_COLUMNS

NO_VEHICLE = -1
"""The row index `neighbours` gives where there is no such vehicle."""
_CONTINUOUS = ("x_m", "y_m", "speed_mps", "acceleration_mps2", "lane_position_m")


def resampled(tracks: pd.DataFrame, frame_rate_hz: float) -> pd.DataFrame:
    """`tracks` (rows of `TRACK_COLUMNS`) at `frame_rate_hz` [Hz]: each vehicle at the frames k / rate [s] within its
    track, positions, speeds, accelerations and heading interpolated linearly, the edge, lane, size and class taken
    from the latest row at or before each frame; a `frame` column holds k. Sorted by vehicle and frame."""
    parts = []
    for _, track in tracks.sort_values(["vehicle_id", "time_s"], kind="stable").groupby("vehicle_id", sort=True):
        times = track["time_s"].to_numpy()
        # a frame within a thousandth of a frame of a row's time is that row's (times carry rounding errors)
        frames = np.arange(np.ceil(times[0] * frame_rate_hz - 1e-3), np.floor(times[-1] * frame_rate_hz + 1e-3) + 1)
        if frames.size == 0:
            continue
        at = frames / frame_rate_hz
        latest = np.clip(np.searchsorted(times, at + 1e-9, side="right") - 1, 0, len(times) - 1)
        part = track.iloc[latest].reset_index(drop=True)
        for column in _CONTINUOUS:
            part[column] = np.interp(at, times, track[column].to_numpy())
        heading = np.unwrap(np.radians(track["heading_deg"].to_numpy()))
        part["heading_deg"] = np.mod(np.degrees(np.interp(at, times, heading)), 360.0)
        part["time_s"] = at
        part["frame"] = frames.astype(np.int64)
        parts.append(part)
    if not parts:
        return pd.DataFrame(columns=[*TRACK_COLUMNS, "frame"])
    return pd.concat(parts, ignore_index=True)


@dataclass(frozen=True)
class Neighbours:
    """Row indices (or NO_VEHICLE) of each row's nearest vehicles in the same frame."""

    preceding: np.ndarray
    following: np.ndarray
    left_preceding: np.ndarray
    left_alongside: np.ndarray
    left_following: np.ndarray
    right_preceding: np.ndarray
    right_alongside: np.ndarray
    right_following: np.ndarray


def neighbours(frame: np.ndarray, lane: np.ndarray, front_m: np.ndarray, length_m: np.ndarray) -> Neighbours:
    """Each row's neighbours among the rows of the same `frame`, from the lane index (left = lane + 1) and the
    front's position along the road [m]: preceding / following in its lane are the next vehicle ahead / behind;
    in a lane beside it, alongside is the nearest vehicle overlapping it lengthwise, preceding the nearest one
    wholly ahead and following the nearest one wholly behind."""
    span = float(np.ptp(front_m)) + 2.0 * float(length_m.max(initial=0.0)) + 10.0
    offset = front_m.min(initial=0.0) - float(length_m.max(initial=0.0)) - 1.0
    lane_key = (frame.astype(np.float64) * (lane.max(initial=0) + 3) + lane + 1) * span
    keys = lane_key + (front_m - offset)
    order = np.argsort(keys, kind="stable")
    sorted_keys, sorted_lane_key = keys[order], lane_key[order]

    def in_lane(positions: np.ndarray, wanted: np.ndarray) -> np.ndarray:
        inside = (positions >= 0) & (positions < len(order))
        safe = np.clip(positions, 0, len(order) - 1)
        found = inside & (sorted_lane_key[safe] == wanted)
        return np.where(found, order[safe], NO_VEHICLE)

    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    preceding, following = in_lane(rank + 1, lane_key), in_lane(rank - 1, lane_key)
    rear = front_m - length_m
    beside = {}
    for side, shift in (("left", 1), ("right", -1)):
        other_key = lane_key + shift * span
        first_after_rear = np.searchsorted(sorted_keys, other_key + (rear - offset), side="right")
        candidate = in_lane(first_after_rear, other_key)
        overlaps = (candidate != NO_VEHICLE) & (rear[np.maximum(candidate, 0)] < front_m)
        alongside = np.where(overlaps, candidate, NO_VEHICLE)
        ahead = np.where(overlaps, in_lane(first_after_rear + 1, other_key), candidate)
        ahead_overlaps = (ahead != NO_VEHICLE) & (rear[np.maximum(ahead, 0)] < front_m)
        beside[side] = (np.where(ahead_overlaps, NO_VEHICLE, ahead), alongside,
                        in_lane(first_after_rear - 1, other_key))
    return Neighbours(preceding, following, *beside["left"], *beside["right"])


def headways(front_m: np.ndarray, speed_mps: np.ndarray, length_m: np.ndarray,
             preceding: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance headway (front to front [m]), time headway (that over the speed [s]) and time to collision (bumper
    gap over the closing speed [s]) to each row's `preceding` row; 0 where there is none or it is not closing, as
    highD writes them."""
    has = preceding != NO_VEHICLE
    ahead = np.maximum(preceding, 0)
    distance = np.where(has, front_m[ahead] - front_m, 0.0)
    time = np.where(has & (speed_mps > 0), distance / np.maximum(speed_mps, 1e-9), 0.0)
    closing = speed_mps - speed_mps[ahead]
    gap = distance - length_m[ahead]
    ttc = np.where(has & (closing > 0), gap / np.maximum(closing, 1e-9), 0.0)
    return distance, time, ttc
