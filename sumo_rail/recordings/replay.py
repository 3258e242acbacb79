"""Non-reactive replay of a scene in SUMO: every recorded vehicle enters, moves (moveToXY, every step) and leaves
exactly as recorded. The ego's seat and the reactive mode build on this (not yet here)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from sumo_rail.recordings.scene import SceneMeta
from sumo_rail.sim import network
from sumo_rail.sim.sumo_api import load_api

KEEP_ROUTE_ANY_EDGE = 2
"""moveToXY's keepRoute: place the vehicle on the recorded edge and lane, off its route if need be."""


def read_scene(folder: Path) -> tuple[SceneMeta, pd.DataFrame]:
    """The scene folder's meta and tracks."""
    folder = Path(folder)
    meta = SceneMeta(**json.loads((folder / "scene.json").read_text()))
    return meta, pd.read_parquet(folder / "tracks.parquet")


class ScenePlayer:
    """One libsumo simulation of a scene's network, stepped at the scene's frame rate, each frame's vehicles placed
    where the recording has them."""

    def __init__(self, folder: Path) -> None:
        self.meta, tracks = read_scene(folder)
        net = Path(self.meta.network)
        net = net if net.is_absolute() else Path(folder) / net
        self.step_length_s = 1.0 / self.meta.frame_rate_hz
        self.frames = {time: frame for time, frame in tracks.groupby(np.round(tracks["time_s"], 6), sort=True)}
        self._offset_s = self.step_length_s - min(self.frames)
        """SUMO's time minus the scene's [s]: the first frame is SUMO's first step (SUMO begins at 0)."""
        self._api: Any = load_api("libsumo")
        self._api.start([network.sumo_binary("sumo"), "-n", str(net), "--step-length", str(self.step_length_s),
                         "--begin", "0", "--no-step-log", "true",
                         "--no-warnings", "true", "--collision.action", "none"])
        self._routes: set[str] = set()
        self._present: set[str] = set()

    def play(self, time_s: float) -> None:
        """Place the vehicles of the frame at `time_s` [s] and step SUMO to it; vehicles absent from it leave."""
        api, frame = self._api, self.frames[round(time_s, 6)]
        ids = frame["vehicle_id"].tolist()
        for vehicle in self._present.difference(ids):
            api.vehicle.remove(vehicle)
        for vehicle, x, y, angle, edge, lane, speed, length, width in zip(
                ids, frame["x_m"].tolist(), frame["y_m"].tolist(), frame["heading_deg"].tolist(),
                frame["edge"].tolist(), frame["lane"].tolist(), frame["speed_mps"].tolist(),
                frame["length_m"].tolist(), frame["width_m"].tolist(), strict=True):
            if vehicle not in self._present:
                route = f"replay_{edge}"
                if route not in self._routes:
                    api.route.add(route, [edge])
                    self._routes.add(route)
                api.vehicle.add(vehicle, route, departLane=str(lane), departSpeed=str(speed))
                api.vehicle.setLength(vehicle, length)
                api.vehicle.setWidth(vehicle, width)
                api.vehicle.setSpeedMode(vehicle, 0)
                api.vehicle.setLaneChangeMode(vehicle, 0)
            api.vehicle.moveToXY(vehicle, edge, lane, x, y, angle, KEEP_ROUTE_ANY_EDGE)
        self._present = set(ids)
        api.simulationStep(time_s + self._offset_s)

    def positions(self) -> dict[str, tuple[float, float]]:
        """Each vehicle's SUMO position [m] (front bumper centre)."""
        return {vehicle: self._api.vehicle.getPosition(vehicle) for vehicle in self._api.vehicle.getIDList()}

    def close(self) -> None:
        self._api.close()
