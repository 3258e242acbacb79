"""The one trajectory record: a vehicle at an instant of a recorded track or of a driven episode (`TrajectoryPoint`),
as demonstrations (`recorded_demos`), seats (`seat`) and evaluations (`evaluation.scene_evaluation`) read and write
it; and the scene at an instant that such points are read off (`SceneSnapshot`, what `SceneFrames.at` gives).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

import numpy as np
import pandas as pd

from sumo_rail.sim.ego_past import EgoPast
from sumo_rail.sim.traffic import leader_gap_m


class TrajectoryPoint(NamedTuple):
    """One vehicle at one instant."""

    time_s: float
    """[s] on the scene's clock."""
    x_m: float
    """[m] network x of the front bumper's centre."""
    y_m: float
    """[m] network y of the front bumper's centre."""
    speed_mps: float
    lane: int
    """SUMO's lane index, 0 = rightmost."""
    lane_position_m: float
    """[m] the front bumper's position along the lane."""
    gap_m: float = math.nan
    """[m] from its front bumper to the rear of the nearest vehicle ahead in its lane; NaN where not measured."""


TRAJECTORY_COLUMNS = TrajectoryPoint._fields
"""The columns of a table of `TrajectoryPoint`s (`trajectory_frame`)."""


def trajectory_frame(points: Sequence[TrajectoryPoint]) -> pd.DataFrame:
    """`points` as a table, one row each, columns `TRAJECTORY_COLUMNS`."""
    return pd.DataFrame(points, columns=list(TRAJECTORY_COLUMNS))


class SceneSnapshot(NamedTuple):
    """Every vehicle of a scene at one instant, one entry each, in the order of their ids."""

    ids: np.ndarray
    values: dict[str, np.ndarray]
    """x_m, y_m, speed_mps, lane_position_m, heading_deg, length_m, width_m (floats) and edge (the edge ids)."""
    lanes: np.ndarray

    def row(self, vehicle: str) -> int | None:
        """The entry of `vehicle` (None when it is not on the road then)."""
        found = np.flatnonzero(self.ids == vehicle)
        return int(found[0]) if len(found) else None

    def point(self, row: int, time_s: float) -> TrajectoryPoint:
        """Entry `row` as the trajectory point at `time_s` [s] (its gap not measured)."""
        x, y, speed, along = (float(self.values[name][row]) for name in ("x_m", "y_m", "speed_mps", "lane_position_m"))
        return TrajectoryPoint(time_s, x, y, speed, int(self.lanes[row]), along)

    def leader_gap_m(self, row: int) -> float:
        """[m] from entry `row`'s front bumper to the rear of the nearest vehicle ahead in its lane (inf: none)."""
        return leader_gap_m(self.lanes, self.values["lane_position_m"], self.values["length_m"], row)


PAST_COLUMNS = ("time_s", "speed_mps", "acceleration_mps2", "lane")
"""The track columns an ego's past holds (`track_past`)."""


def track_past(rows: pd.DataFrame | Mapping[str, np.ndarray]) -> EgoPast:
    """A track's rows (`PAST_COLUMNS` at least, in time order; a DataFrame or arrays by column) as the ego's past the
    observation's history block reads."""
    return EgoPast(*(np.asarray(rows[name]) for name in PAST_COLUMNS))
