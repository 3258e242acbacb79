"""The data an IDM is fitted on (`idm_calibration`): a scene's tracks on SUMO's step with each row's leader, and the
windows in which a driver keeps its lane and follows one leader.

- `scene_rows`: the tracks at every multiple of SUMO's step they cover (resampled when the frame period differs:
  positions and speeds interpolated, lane and edge the latest frame's), each row with its leader: the nearest vehicle
  ahead on the same edge and lane at that instant, and the bumper-to-bumper gap to its rear.
- `follow_windows`: from every `sample_s` of each chosen driver's track, a window of `horizon_s` in which the driver
  keeps its edge and lane and has one and the same leader at every step (or none throughout), the leader's track
  covering the window: its start, the leader's travel and speed at each step, the driver's recorded speeds.
- `speed_floor`: the lowest desired speed a driver's rows allow: the `quantile` of its speeds where no leader is within
  `free_gap_m` (of all its speeds when it never is), and never below its last speed (IDM drives no faster than its
  desired speed).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class SceneRows:
    """A scene's tracks on SUMO's step, sorted by vehicle and tick, each row with its leader (`leader`: the row of
    the nearest vehicle ahead on the same edge and lane at the same tick, -1 for none; `gap_m` to its rear, np.inf
    for none)."""

    vehicle: np.ndarray
    tick: np.ndarray
    """Time in SUMO steps."""
    position_m: np.ndarray
    """Front bumper along the lane [m]."""
    speed_mps: np.ndarray
    lane: np.ndarray
    edge: np.ndarray
    length_m: np.ndarray
    leader: np.ndarray
    gap_m: np.ndarray
    last: np.ndarray
    """The row of the same vehicle's last tick."""


def _on_ticks(tracks: pd.DataFrame, step_s: float) -> pd.DataFrame:
    """The tracks at every multiple of `step_s` [s] they cover (the rows themselves when they lie on the ticks)."""
    ticks = tracks["time_s"].to_numpy() / step_s
    if np.allclose(ticks, np.rint(ticks), rtol=0.0, atol=1e-6):
        return tracks.assign(tick=np.rint(ticks).astype(np.int64))
    parts = []
    for vehicle, track in tracks.sort_values("time_s").groupby("vehicle_id", sort=False):
        time_s = track["time_s"].to_numpy()
        tick = np.arange(np.ceil(time_s[0] / step_s - 1e-6), np.floor(time_s[-1] / step_s + 1e-6) + 1)
        at_s = tick * step_s
        latest = np.clip(np.searchsorted(time_s, at_s + 1e-9, side="right") - 1, 0, len(time_s) - 1)
        parts.append(pd.DataFrame({
            "vehicle_id": vehicle, "tick": tick.astype(np.int64),
            "lane_position_m": np.interp(at_s, time_s, track["lane_position_m"].to_numpy()),
            "speed_mps": np.interp(at_s, time_s, track["speed_mps"].to_numpy()),
            "lane": track["lane"].to_numpy()[latest], "edge": track["edge"].to_numpy()[latest],
            "length_m": track["length_m"].to_numpy()[latest]}))
    return pd.concat(parts, ignore_index=True)


def scene_rows(tracks: pd.DataFrame, step_s: float) -> SceneRows:
    """`tracks` (a scene's `TRACK_COLUMNS`) on SUMO's step `step_s` [s] with every row's leader."""
    table = _on_ticks(tracks, step_s).sort_values(["vehicle_id", "tick"], ignore_index=True)
    vehicle = table["vehicle_id"].to_numpy().astype(str)
    tick = table["tick"].to_numpy()
    position = table["lane_position_m"].to_numpy(dtype=np.float64)
    lane = table["lane"].to_numpy().astype(np.int64)
    edge = pd.factorize(table["edge"])[0]
    length = table["length_m"].to_numpy(dtype=np.float64)
    order = np.lexsort((position, lane, edge, tick))
    same = ((tick[order][1:] == tick[order][:-1]) & (edge[order][1:] == edge[order][:-1])
            & (lane[order][1:] == lane[order][:-1]))
    leader = np.full(len(table), -1, dtype=np.int64)
    leader[order[:-1][same]] = order[1:][same]
    has = leader >= 0
    gap = np.full(len(table), np.inf)
    gap[has] = position[leader[has]] - length[leader[has]] - position[has]
    ends = np.flatnonzero(np.append(vehicle[1:] != vehicle[:-1], True))
    last = np.repeat(ends, np.diff(np.append(-1, ends)))
    return SceneRows(vehicle, tick, position, table["speed_mps"].to_numpy(dtype=np.float64), lane, edge, length,
                     leader, gap, last)


def speed_floor(speed_mps: np.ndarray, gap_m: np.ndarray, free_gap_m: float, quantile: float) -> float:
    """The lowest desired speed [m/s] a driver's rows (speeds, gaps to their leaders) allow (module docstring)."""
    free = gap_m >= free_gap_m
    pool = speed_mps[free] if free.any() else speed_mps
    return float(max(np.quantile(pool, quantile), speed_mps[-1]))


@dataclass(frozen=True)
class Windows:
    """Windows of drivers `drivers` (`driver`: each window's index into it; `floor_mps`: each driver's
    `speed_floor`): each window's start (the driver's position, speed and gap, np.inf without a leader) and, for each
    of its H steps, the leader's travel since the start and its speed at the step's beginning, and the driver's
    recorded speed at its end."""

    drivers: np.ndarray
    floor_mps: np.ndarray
    driver: np.ndarray
    position_m: np.ndarray
    speed_mps: np.ndarray
    gap_m: np.ndarray
    leader_travel_m: np.ndarray
    leader_speed_mps: np.ndarray
    recorded_mps: np.ndarray
    recorded_travel_m: np.ndarray
    """How far the driver went in the window [m]."""

    def __len__(self) -> int:
        return len(self.driver)

    def subset(self, keep: np.ndarray) -> Windows:
        """The windows at the indices (or mask) `keep`, of the same drivers."""
        return Windows(self.drivers, self.floor_mps, *(value[keep] for name, value in self.__dict__.items()
                                                        if name not in ("drivers", "floor_mps")))


def follow_windows(rows: SceneRows, vehicles: Collection[str], horizon_s: float, sample_s: float, step_s: float,
                   free_gap_m: float, quantile: float, span_s: tuple[float, float] | None = None) -> Windows:
    """The windows of `vehicles` (module docstring): `horizon_s` long, one every `sample_s` [s] of a track; with
    `span_s` (from, to) [s] only those within that span after the track's first instant, of the tracks that cover it
    (the seats of `evaluate-scene`: its --lead-s and --lead-s + --horizon-s)."""
    steps, every = round(horizon_s / step_s), max(1, round(sample_s / step_s))
    chosen = np.isin(rows.vehicle, list(vehicles))
    first_row = np.searchsorted(rows.vehicle, rows.vehicle, side="left")
    since = rows.tick - rows.tick[first_row]
    if span_s is not None:
        begin, end = round(span_s[0] / step_s), round(span_s[1] / step_s)
        chosen &= (since >= begin) & (since + steps <= end) & (rows.tick[rows.last] - rows.tick[first_row] >= end)
    start = np.flatnonzero(chosen & ((rows.tick - rows.tick[first_row]) % every == 0)
                           & (np.arange(len(rows.tick)) + steps <= rows.last))
    offsets = np.arange(steps + 1)
    own = start[:, None] + offsets
    keep = ((rows.tick[own] == rows.tick[start][:, None] + offsets).all(axis=1)
            & (rows.lane[own] == rows.lane[start][:, None]).all(axis=1)
            & (rows.edge[own] == rows.edge[start][:, None]).all(axis=1))
    lead = rows.leader[start]
    has = lead >= 0
    followed = np.where(has[:, None], lead[:, None] + offsets, -1)
    safe = np.clip(followed, 0, len(rows.tick) - 1)
    keep &= (rows.leader[own] == followed).all(axis=1)
    keep &= ~has | ((followed <= rows.last[np.maximum(lead, 0)][:, None]).all(axis=1)
                    & (rows.tick[safe] == rows.tick[start][:, None] + offsets).all(axis=1))
    start, own, has, safe = start[keep], own[keep], has[keep], safe[keep][:, :steps]
    drivers, driver = np.unique(rows.vehicle[start], return_inverse=True)
    firsts = first_row[start][np.unique(driver, return_index=True)[1]]
    floors = np.array([speed_floor(rows.speed_mps[first:rows.last[first] + 1], rows.gap_m[first:rows.last[first] + 1],
                                   free_gap_m, quantile) for first in firsts])
    travel = np.where(has[:, None], rows.position_m[safe] - rows.position_m[safe[:, :1]], 0.0)
    return Windows(drivers, floors, driver, rows.position_m[start], rows.speed_mps[start], rows.gap_m[start], travel,
                   np.where(has[:, None], rows.speed_mps[safe], 0.0), rows.speed_mps[own[:, 1:]],
                   rows.position_m[own[:, -1]] - rows.position_m[start])
