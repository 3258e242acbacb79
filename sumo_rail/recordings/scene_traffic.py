"""The recorded vehicles of a scene as the traffic of a running SUMO, in one of two modes:

- non-reactive (nuPlan's and Waymax's log replay): before every SUMO step each vehicle of the recording is moved
  (`moveToXY`, its recorded lane kept) to where the recording has it at the step's end; it enters when its track
  begins and leaves when it ends, whatever anyone else does. SUMO gives it the speed its move implies, so the ego's
  car following sees the recorded speeds.
- reactive: each vehicle is placed once at its recorded state (position, lane, speed) where its track begins (or at
  the ego's start, when it is on the road then) and from the next step on driven by SUMO's car following and lane
  changing (SUMO's default Krauss type, its desired speed the fastest speed its track records), so it reacts to the
  ego; it leaves at the end of the road.

The vehicle whose seat the ego takes is never placed. Positions between two frames are interpolated
(`SceneFrames.at`), so a scene of any frame rate plays at the simulation's step. Non-reactive vehicles farther than
`REPLAY_RADIUS_M` from the ego along the road are not in SUMO at all: their recorded path does not depend on
anything, and from there they reach neither the ego's perception (LIDAR range + context margin, 120 m by default)
nor its car following (SUMO's leader search reaches its braking distance, 330 m at 44 m/s with the ACC's 3 m/s^2);
they enter at their recorded place when they come within it (tests show the same observations, and a SUMO-driven
seat the same speeds, with every vehicle in SUMO).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.recordings.scene_observations import SceneFrames

KEEP_ROUTE_ANY_EDGE = 2
"""moveToXY's keepRoute: place the vehicle on the recorded edge and lane, off its route if need be."""
SPEED_MODE_SUMO = 31
"""SUMO's default speed mode: every safety check on (a released reactive vehicle)."""
LANE_CHANGE_MODE_SUMO = 1621
"""SUMO's default lane-change mode (a released reactive vehicle changes lanes as LC2013 decides)."""
REPLAY_RADIUS_M = 500.0
"""Non-reactive vehicles are in SUMO while within this distance of the ego along the road [m]."""
REPLAY_ROUTE = "scene_replay"
"""The route (the scene's one edge) every recorded vehicle is added on."""


class SceneTraffic:
    """The recorded vehicles of `frames` on edge `edge` of a running SUMO `api` (one that has the route
    `REPLAY_ROUTE`); `reactive` chooses the mode, `speed_limit_mps` is the edge's limit [m/s]."""

    def __init__(self, frames: SceneFrames, tracks: pd.DataFrame, edge: str, reactive: bool,
                 speed_limit_mps: float) -> None:
        self.frames = frames
        self.edge = edge
        self.reactive = reactive
        self.api: Any = None
        """The SUMO connection (set by the simulation once it has started)."""
        spans = tracks.groupby("vehicle_id")["time_s"].min().sort_values()
        self._begins_s = spans.to_numpy()
        """Each track's first time [s], sorted: the reactive mode looks for vehicles to place only when one begins."""
        top = tracks.groupby("vehicle_id")["speed_mps"].max()
        self._speed_factor = dict(zip(top.index.astype(str), top.to_numpy() / speed_limit_mps, strict=True))
        """Each vehicle's desired speed in the reactive mode, as a share of the limit."""
        self._skip = ""
        self._placed: set[str] = set()
        """Vehicles placed so far (reactive: they are SUMO's from the step after)."""
        self._releasing: list[str] = []
        self._last_s = -np.inf

    def begin(self, skip: str) -> None:
        """A new episode in a freshly loaded SUMO: nothing placed yet; vehicle `skip` (the ego's seat) never is."""
        self._skip = skip
        self._placed.clear()
        self._releasing.clear()
        self._last_s = -np.inf

    def place(self, time_s: float, ego_x_m: float | None) -> None:
        """Put the recorded vehicles where the recording has them at `time_s` [s]; call before the SUMO step that
        ends at `time_s`. `ego_x_m`: the ego's x [m] (None before it is on the road: the recorded x of its seat)."""
        if self.reactive:
            self._release()
            begun = np.searchsorted(self._begins_s, [self._last_s, time_s], side="right")
            first, self._last_s = not self._placed, time_s
            if not first and begun[0] == begun[1]:
                return  # no track begins in this step: nothing to place
        ids, values, lanes = self.frames.at(time_s)
        if not self.reactive:
            if ego_x_m is None:
                seat = np.flatnonzero(ids == self._skip)
                ego_x_m = float(values["x_m"][seat[0]]) if len(seat) else None
            if ego_x_m is not None:
                near = np.abs(values["x_m"] - ego_x_m) <= REPLAY_RADIUS_M
                ids, lanes, values = ids[near], lanes[near], {name: column[near] for name, column in values.items()}
        vehicle = self.api.vehicle
        on_road = set(vehicle.getIDList())
        if not self.reactive:
            for gone in self._placed.difference(ids.tolist()):
                if gone in on_road:
                    vehicle.remove(gone)
            self._placed.intersection_update(ids.tolist())
        x, y, heading, speed = values["x_m"], values["y_m"], values["heading_deg"], values["speed_mps"]
        for k, name in enumerate(ids.tolist()):
            if name == self._skip or (self.reactive and name in self._placed):
                continue
            if name not in on_road:  # new, or (non-reactive) removed by SUMO after a collision: placed again
                vehicle.add(name, REPLAY_ROUTE, departLane=str(lanes[k]), departSpeed=repr(float(speed[k])))
                vehicle.setLength(name, float(values["length_m"][k]))
                vehicle.setWidth(name, float(values["width_m"][k]))
                vehicle.setSpeedMode(name, 0)
                vehicle.setLaneChangeMode(name, 0)
                self._placed.add(name)
                if self.reactive:
                    self._releasing.append(name)
            elif self.reactive:
                continue
            vehicle.moveToXY(name, self.edge, int(lanes[k]), float(x[k]), float(y[k]), float(heading[k]),
                             KEEP_ROUTE_ANY_EDGE)

    def _release(self) -> None:
        """Hand the vehicles placed before the last step to SUMO's models (reactive mode)."""
        vehicle = self.api.vehicle
        on_road = set(vehicle.getIDList()) if self._releasing else set()
        for name in self._releasing:
            if name in on_road:
                vehicle.setSpeedMode(name, SPEED_MODE_SUMO)
                vehicle.setLaneChangeMode(name, LANE_CHANGE_MODE_SUMO)
                vehicle.setSpeedFactor(name, float(self._speed_factor[name]))
        self._releasing.clear()

