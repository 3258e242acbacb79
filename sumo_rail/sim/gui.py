"""sumo-gui for `Simulation`: its window, view settings and pace, and following the ego. No traci import here:
the functions work on the traci API object the simulation passes in."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

from sumo_rail.datasets import write_bytes_atomically
from sumo_rail.sim import network

VIEW = "View #0"
"""sumo-gui's main view."""
VIEW_HALF_WIDTH_M = 65.0
"""sumo-gui shows this much road before and behind the ego while following it [m]."""
WINDOW_SIZE = "1280,800"
"""sumo-gui's window size [px]."""


def follow(api: Any, vehicle: str) -> None:
    """Draw `vehicle` in red and point the view at it: tracked, with VIEW_HALF_WIDTH_M of road either side."""
    api.vehicle.setColor(vehicle, (255, 0, 0, 255))
    x, y = api.vehicle.getPosition(vehicle)
    half = VIEW_HALF_WIDTH_M
    api.gui.setBoundary(VIEW, x - half, y - half / 2, x + half, y + half / 2)  # the zoom, whatever the road
    api.gui.trackVehicle(VIEW, vehicle)


class PacedApi:
    """The traci API with `simulationStep` paced: each step starts at least `step_wall_s` [s] of wall time after
    the previous one (0: no pacing), so sumo-gui shows the episode at a watchable speed; `clock` and `sleep` are
    time.monotonic and time.sleep."""

    def __init__(self, api: ModuleType, step_wall_s: float, clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self._api = api
        self._step_wall_s = step_wall_s
        self._clock = clock
        self._sleep = sleep
        self._last: float | None = None

    def simulationStep(self, *args: Any) -> Any:
        if self._step_wall_s > 0 and self._last is not None:
            wait = self._last + self._step_wall_s - self._clock()
            if wait > 0:
                self._sleep(wait)
        self._last = self._clock()
        return self._api.simulationStep(*args)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._api, name)


@contextlib.contextmanager
def unpaced(api: ModuleType | PacedApi) -> Iterator[None]:
    """Steps at full speed within the block, also when `api` is paced."""
    if not isinstance(api, PacedApi):
        yield
        return
    step_wall_s, api._step_wall_s = api._step_wall_s, 0.0
    try:
        yield
    finally:
        api._step_wall_s = step_wall_s


def settings_file() -> Path:
    """sumo-gui view settings: the "real world" scheme, vehicles drawn as their type's shape."""
    path = network.cache_dir() / "gui-settings-v2.xml"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomically(path, b'<viewsettings>\n    <scheme name="real world"/>\n</viewsettings>\n')
    return path
