"""What a built road is (`BuiltNetwork`) and where SUMO's programs are: shared by the generated roads (`network`)
and a user's own network (`user_network`)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class BuiltNetwork:
    """Paths of a built scenario and the ego's route on it."""

    net_file: Path
    routes_file: Path
    directory: Path
    ego_route: tuple[str, ...]
    """The ego's edges, in order (`route_id` in the routes file)."""
    traffic_file: Path | None = None
    """A user's own traffic (kind network), loaded after `routes_file`."""
    route_id: str = "ego_route"
    """The ego's route in the routes file."""
    route_length_m: float | None = None
    """The length of a user's route (kind network) [m]; None on the generated roads (scenario.length_m)."""
    speed_limit_mps: float | None = None
    """The highest speed limit along a user's route (kind network) [m/s]; None on the generated roads
    (scenario.speed_limit_mps)."""
    exit_at_m: float | None = None
    """Where a user's route leaves the main road (kind network), along the route [m]; None where it keeps to it."""
    start_lanes: int = 1
    """Lanes of the route's first edge, where the ego starts."""

    @property
    def route_files(self) -> str:
        """SUMO's --route-files value."""
        return ",".join(str(path) for path in (self.routes_file, self.traffic_file) if path is not None)


def sumo_binary(name: str) -> str:
    """Path of a SUMO executable (sumo, sumo-gui, netconvert) from the eclipse-sumo package."""
    import sumo

    return os.path.join(sumo.SUMO_HOME, "bin", name)
