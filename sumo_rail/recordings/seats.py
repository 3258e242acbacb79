"""Seats in a recorded scene: which recorded vehicles an ego may take the place of, and where.

A seat is a vehicle of the chosen split and classes whose track covers the seat's lead-in and horizon; it begins
`lead_s` into the track or, with `zone_m`, where traffic is established (`choose_seats`). `SeatDraw` draws one of a
scene's seats by an episode's generator, for `SceneEnv` reset without a vehicle (Gymnasium and its vector envs).
"""

from __future__ import annotations

import math
from collections.abc import Collection
from dataclasses import dataclass, field

import numpy as np

from sumo_rail.recordings.scene import SPLITS, Scene
from sumo_rail.recordings.scene_observations import scene_road, scene_routes


@dataclass(frozen=True)
class Seat:
    """A recorded vehicle's seat: its scene folder, id and the instant the ego takes it [s]; its phase there: how far
    along the road the vehicle is [m] and how long since its track began [s] (NaN where not known)."""

    scene: str
    vehicle: str
    start_s: float
    entry_distance_m: float = float("nan")
    since_entry_s: float = float("nan")


def choose_seats(scene: Scene, split: str, horizon_s: float, lead_s: float, limit: int | None,
                 seed: int, *, zone_m: float = 0.0, classes: Collection[str] = ("passenger",),
                 earliest_s: float = 0.0) -> list[Seat]:
    """The seats of `split`'s vehicles of `classes` (passenger cars by default) whose tracks cover `lead_s` +
    `horizon_s`, in id order; with `limit`, that many drawn without replacement by `seed`, kept in id order. A seat
    begins `lead_s` into the track; with `zone_m` > 0 [m], where traffic is established: at the first row from then on
    where the vehicle is at least `zone_m` along the road, its horizon ending at least `zone_m` before the road's end
    (vehicles that never fit are left out). No seat starts before `earliest_s` [s] (SUMO's run begins one step before
    the seat: give the step length; a track from the scene's first instant is then taken one step in)."""
    held_out = set(scene.split.loc[scene.split["split"] == split, "vehicle_id"].astype(str))
    spans = scene.tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                                   kind=("vehicle_class", "first"))
    fit = spans[spans["kind"].isin(list(classes)) & (spans["end"] - spans["begin"] >= lead_s + horizon_s - 1e-9)
                & spans.index.isin(held_out)].sort_index()
    road, routes = scene_road(scene.network), scene_routes(scene.tracks)
    rows = scene.tracks[scene.tracks["vehicle_id"].isin(fit.index)].sort_values(["vehicle_id", "time_s"],
                                                                                 kind="stable")
    seats = []
    for vehicle, track in rows.groupby("vehicle_id", sort=True):
        route, time_s = routes[str(vehicle)], track["time_s"].to_numpy(dtype=float)
        along = road.place(route, track["edge"].to_numpy().astype(str), track["lane"].to_numpy(),
                           track["lane_position_m"].to_numpy(dtype=float))[0]  # along its route, across edges
        start = _seat_start(time_s, along, max(lead_s, earliest_s - float(time_s[0])), horizon_s, zone_m,
                            road.frame(route).length_m)
        if start is not None:
            seats.append(Seat(str(scene.folder), str(vehicle), start[0], start[1], start[0] - float(time_s[0])))
    if limit is not None and limit < len(seats):
        seats = [seats[k] for k in np.sort(np.random.default_rng(seed).choice(len(seats), limit, replace=False))]
    return seats


def _seat_start(time_s: np.ndarray, along: np.ndarray, lead_s: float, horizon_s: float, zone_m: float,
                length_m: float) -> tuple[float, float] | None:
    """(start [s], position along the route there [m]) of a track's seat (`choose_seats`) from its times [s] and
    positions along its route [m] (-inf where off it); None when none fits."""
    start_s = float(time_s[0]) + lead_s
    if time_s[-1] < start_s + horizon_s - 1e-9:
        return None
    if zone_m > 0:
        later = np.flatnonzero((time_s >= start_s - 1e-9) & (along >= zone_m))
        if not len(later):
            return None
        start_s = float(time_s[later[0]])
        if time_s[-1] < start_s + horizon_s - 1e-9 or np.interp(start_s + horizon_s, time_s, along) > length_m - zone_m:
            return None
    return start_s, float(np.interp(start_s, time_s, along))


@dataclass
class SeatDraw:
    """Draws a seat of `scene` for an episode: one of `choose_seats(scene, split, horizon_s, lead_s, zone_m=zone_m,
    earliest_s=earliest_s)`, uniformly by the episode's generator (the list made at the first draw)."""

    scene: Scene
    split: str
    horizon_s: float
    lead_s: float
    zone_m: float
    earliest_s: float
    _seats: list[Seat] | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        """ValueError, one sentence, for a split that is none of the scene's or a lead-in or zone that is not a finite
        number of at least 0 (a negative lead-in seated the ego before its car's track began)."""
        if self.split not in SPLITS:
            raise ValueError(f"unknown split {self.split!r}; known: {', '.join(SPLITS)}")
        for name, value in (("lead_s", self.lead_s), ("zone_m", self.zone_m)):
            if not 0.0 <= value < math.inf:
                raise ValueError(f"{name} must be a finite number of at least 0, got {value:g}")

    def draw(self, rng: np.random.Generator) -> Seat:
        """A seat drawn by `rng`; ValueError, one sentence, when the scene has none."""
        if self._seats is None:
            self._seats = choose_seats(self.scene, self.split, self.horizon_s, self.lead_s, None, 0,
                                       zone_m=self.zone_m, earliest_s=self.earliest_s)
        if not self._seats:
            zone = f" {self.zone_m:g} m from the road's entry and end" if self.zone_m > 0 else ""
            raise ValueError(f"no {self.split}-split car of the scene {self.scene.folder} has a track covering the "
                             f"seat's lead-in {self.lead_s:g} s and env.max_episode_s {self.horizon_s:g} s{zone}")
        return self._seats[int(rng.integers(len(self._seats)))]
