"""The data an IDM is fitted on (`idm_calibration`): a scene's tracks on SUMO's step with each row's leader, and the
windows in which a driver keeps its lane and follows one leader.

- `scene_rows`: the tracks at every multiple of SUMO's step they cover (resampled when the frame period differs, a
  multiple of the step too: positions along the vehicle's route and speeds interpolated, lane and edge the latest
  frame's), each row with its
  leader: the nearest vehicle ahead along the driver's route (its recorded edges, `scene_observations.scene_routes`)
  in the same lane of that route at that instant, on its edge or the next ones it takes (the route frame of
  `scene_observations.SceneRoad`, as the observation and the seat measure distances on any network), and the
  bumper-to-bumper gap to its rear along that route.
- `follow_windows`: from every `sample_s` of each chosen driver's track, a window of `horizon_s` in which the driver
  keeps its lane along its route (a change of edge is no lane change) and has one and the same leader at every step
  (or none throughout), the leader's track covering the window: its start, the leader's travel and speed at each
  step, the driver's recorded speeds.
- `speed_floor`: the lowest desired speed a driver's rows allow: the `quantile` of its speeds where no leader is within
  `free_gap_m` (of all its speeds when it never is), and never below its last speed (IDM drives no faster than its
  desired speed).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from sumo_rail.recordings.scene_observations import SceneRoad, scene_routes
from sumo_rail.sim.road import UNPLACED


@dataclass(frozen=True)
class SceneRows:
    """A scene's tracks on SUMO's step, sorted by vehicle and tick, each row with its leader (`leader`: the row of
    the nearest vehicle ahead along the vehicle's route in the same route lane at the same tick, -1 for none; `gap_m`
    to its rear, np.inf for none)."""

    vehicle: np.ndarray
    tick: np.ndarray
    """Time in SUMO steps."""
    position_m: np.ndarray
    """Front bumper along the vehicle's own route [m] (NaN on a lane not linked to it)."""
    speed_mps: np.ndarray
    lane: np.ndarray
    """The lane of the vehicle's own route (`road.UNPLACED`'s on a lane not linked to it)."""
    length_m: np.ndarray
    leader: np.ndarray
    gap_m: np.ndarray
    last: np.ndarray
    """The row of the same vehicle's last tick."""


def _every_tick(vehicle_id: pd.Series, ticks: np.ndarray) -> bool:
    """Whether the frames come every tick: the closest two consecutive frames of a vehicle are one tick apart (or no
    vehicle has two frames, as in a lead-in of one instant)."""
    vehicle = vehicle_id.to_numpy().astype(str)
    order = np.lexsort((ticks, vehicle))
    apart = np.rint(np.diff(ticks[order]))[vehicle[order][1:] == vehicle[order][:-1]]
    return not apart.size or apart.min() <= 1


def _on_ticks(tracks: pd.DataFrame, step_s: float, road: SceneRoad,
              routes: Mapping[str, tuple[str, ...]]) -> pd.DataFrame:
    """The tracks at every multiple of `step_s` [s] they cover: the rows themselves when they lie on the ticks, one
    every tick; else (frames between the ticks, or several ticks apart as SUMO's FCD at its default 1 s step)
    interpolated along each vehicle's route of `routes` on `road`, so that a frame on the next edge is no jump."""
    ticks = tracks["time_s"].to_numpy() / step_s
    if np.allclose(ticks, np.rint(ticks), rtol=0.0, atol=1e-6) and _every_tick(tracks["vehicle_id"], ticks):
        return tracks.assign(tick=np.rint(ticks).astype(np.int64))
    parts = []
    for vehicle, track in tracks.sort_values("time_s").groupby("vehicle_id", sort=False):
        time_s = track["time_s"].to_numpy()
        tick = np.arange(np.ceil(time_s[0] / step_s - 1e-6), np.floor(time_s[-1] / step_s + 1e-6) + 1)
        at_s = tick * step_s
        latest = np.clip(np.searchsorted(time_s, at_s + 1e-9, side="right") - 1, 0, len(time_s) - 1)
        edge, lane, lane_position = (track[name].to_numpy() for name in ("edge", "lane", "lane_position_m"))
        along = road.place(routes[str(vehicle)], edge.astype(str), lane, lane_position)[0]
        on_lane = np.interp(at_s, time_s, along) - (along - lane_position)[latest]  # from the latest frame's lane
        parts.append(pd.DataFrame({
            "vehicle_id": vehicle, "tick": tick.astype(np.int64),
            "lane_position_m": np.where(np.isfinite(on_lane), on_lane, np.interp(at_s, time_s, lane_position)),
            "speed_mps": np.interp(at_s, time_s, track["speed_mps"].to_numpy()),
            "lane": lane[latest], "edge": edge[latest], "length_m": track["length_m"].to_numpy()[latest]}))
    return pd.concat(parts, ignore_index=True)


def scene_rows(tracks: pd.DataFrame, road: SceneRoad, step_s: float,
               routes: Mapping[str, tuple[str, ...]] | None = None) -> SceneRows:
    """`tracks` (a scene's `TRACK_COLUMNS` on the network of `road`) on SUMO's step `step_s` [s] with every row's
    leader along the vehicle's route (`routes`: each vehicle's; None: the edges its rows in `tracks` drive)."""
    routes = scene_routes(tracks) if routes is None else routes
    table = _on_ticks(tracks, step_s, road, routes).sort_values(["vehicle_id", "tick"], ignore_index=True)
    vehicle = table["vehicle_id"].to_numpy().astype(str)
    tick = table["tick"].to_numpy()
    on_lane = table["lane_position_m"].to_numpy(dtype=np.float64)
    length = table["length_m"].to_numpy(dtype=np.float64)
    lane_code, lane_ids = pd.factorize(table["edge"].astype(str) + "_" + table["lane"].astype(str))
    names, name_code = np.unique(vehicle, return_inverse=True)
    route_ids, route_of_name = np.unique([" ".join(routes[name]) for name in names], return_inverse=True)
    route_code = route_of_name[name_code]
    position, lane = np.full(len(table), np.nan), np.full(len(table), UNPLACED[1], dtype=np.int64)
    leader, gap = np.full(len(table), -1, dtype=np.int64), np.full(len(table), np.inf)
    for code, route_id in enumerate(route_ids):  # every vehicle of a route, and its leaders, in that route's frame
        mine = route_code == code
        seen = np.flatnonzero(np.isin(tick, np.unique(tick[mine])))
        starts, route_lanes = road.lane_starts(tuple(route_id.split(" ")), lane_ids.tolist())
        seen_at, seen_lane = starts[lane_code[seen]] + on_lane[seen], route_lanes[lane_code[seen]]
        placed = np.isfinite(seen_at)
        seen, seen_at, seen_lane = seen[placed], seen_at[placed], seen_lane[placed]
        order = np.lexsort((seen_at, seen_lane, tick[seen]))
        same = (tick[seen][order][1:] == tick[seen][order][:-1]) & (seen_lane[order][1:] == seen_lane[order][:-1])
        ahead = np.full(len(seen), -1, dtype=np.int64)
        ahead[order[:-1][same]] = order[1:][same]
        own = mine[seen]
        rows, ahead, at = seen[own], ahead[own], seen_at[own]
        position[rows], lane[rows] = at, seen_lane[own]
        has = ahead >= 0
        leader[rows[has]] = seen[ahead[has]]
        gap[rows[has]] = seen_at[ahead[has]] - length[seen[ahead[has]]] - at[has]
    ends = np.flatnonzero(np.append(vehicle[1:] != vehicle[:-1], True))
    last = np.repeat(ends, np.diff(np.append(-1, ends)))
    return SceneRows(vehicle, tick, position, table["speed_mps"].to_numpy(dtype=np.float64), lane, length,
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
            & (rows.lane[own] == rows.lane[start][:, None]).all(axis=1) & np.isfinite(rows.position_m[own]).all(axis=1))
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
