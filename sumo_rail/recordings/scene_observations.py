"""The env's observation computed from a recorded scene: what the ego of a track would have seen at an instant.

The env observes an ego through one SUMO context subscription (every vehicle whose front is within the LIDAR range
plus `ego.CONTEXT_MARGIN_M` of the ego's front, in the order of their ids) and hands their front bumpers, headings,
speeds, sizes, positions along the road and lanes, the road's edge boxes and the ego's own state to
`kernels.observation_vector`. Here the same function gets the scene's vehicles at the instant (linearly interpolated
between frames when the instant falls between two), the edge boxes of the scene's road (its outer lane sides, as
`Sensing.road_edges` draws them from SUMO) and the route block of a straight one-edge road (`route_values`). What a
track cannot give, the ego's cruise set-point, is an input (`actions.speed_reading` estimates it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError
from sumo_rail.recordings.road import network_root
from sumo_rail.recordings.trajectory import SceneSnapshot
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.network import offset_polyline, segments
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.route_progress import route_values
from sumo_rail.sim.vehicles import EgoState

_FRAME_TOLERANCE = 1e-6
"""An instant within this share of a frame of a frame is that frame."""
_CONTINUOUS = ("x_m", "y_m", "speed_mps", "lane_position_m")


@dataclass(frozen=True)
class SceneRoad:
    """A straight one-edge road: its edge, lane centre lines' y [m] (rightmost first), length [m], the edge boxes
    the LIDAR sees ((S, 6) rows of centre x, y, axis x, y, half length, half width, as `ego.edge_rows`) and its speed
    limit [m/s] (its fastest lane's)."""

    edge: str
    lane_y_m: tuple[float, ...]
    length_m: float
    edge_rows: np.ndarray
    speed_limit_mps: float

    @property
    def lanes(self) -> int:
        """Lanes of the road."""
        return len(self.lane_y_m)


STRAIGHT_ROAD = ("scenes are replayed and read as demonstrations on one straight edge whose lanes run along +x (x "
                 "growing in the driving direction, y constant), as highD, NGSIM and record-sumo-drivers give them")
"""What `scene_road` takes, said in its refusals."""


def scene_road(net_file: Path) -> SceneRoad:
    """The road of a scene's network; DatasetError naming the file when it is not one straight edge along +x
    (`STRAIGHT_ROAD`)."""
    root = network_root(net_file)
    edges = [edge for edge in root.iter("edge") if not edge.get("id", "").startswith(":")]
    if len(edges) != 1:
        raise DatasetError(f"network {net_file} has {len(edges)} edges; {STRAIGHT_ROAD}")
    lanes = sorted(edges[0].iter("lane"), key=lambda lane: int(lane.get("index", "0")))
    shapes = [np.array([[float(value) for value in point.split(",")] for point in lane.get("shape", "").split()])
              for lane in lanes]
    if not lanes or any(len(shape) < 2 or np.ptp(shape[:, 1]) > 1e-6 or shape[-1, 0] <= shape[0, 0]
                        for shape in shapes):
        raise DatasetError(f"network {net_file}: the lanes of edge {edges[0].get('id')} do not run straight along +x; "
                           f"{STRAIGHT_ROAD}")
    widths = [float(lane.get("width", "3.2")) for lane in lanes]
    right = offset_polyline(shapes[0], -widths[0] / 2)
    left = offset_polyline(shapes[-1], widths[-1] / 2)
    boxes = lidar.edge_boxes(np.concatenate([segments(right), segments(left)]))
    return SceneRoad(edges[0].get("id", ""), tuple(float(shape[0, 1]) for shape in shapes),
                     float(lanes[0].get("length", "0")), np.hstack([boxes.centre_xy, boxes.axis_xy,
                                                                     boxes.half_size_m]),
                     max(float(lane.get("speed", "13.89")) for lane in lanes))


class SceneFrames:
    """Every vehicle of a scene at any instant: the rows of each frame, in the order of the vehicles' ids (SUMO's
    context subscription answers in that order)."""

    def __init__(self, tracks: pd.DataFrame, frame_rate_hz: float) -> None:
        self.rate_hz = frame_rate_hz
        self.origin_s = float(tracks["time_s"].min())
        """Time of frame 0 [s]: the first row's (an FCD recording's times count from its start)."""
        frame = np.rint((tracks["time_s"].to_numpy() - self.origin_s) * frame_rate_hz).astype(np.int64)
        ordered = tracks.assign(frame=frame).sort_values(["frame", "vehicle_id"], kind="stable", ignore_index=True)
        self.ids = ordered["vehicle_id"].to_numpy().astype(str)
        self.frame = ordered["frame"].to_numpy()
        self.values = {name: ordered[name].to_numpy(dtype=np.float64)
                       for name in (*_CONTINUOUS, "heading_deg", "length_m", "width_m")}
        self.lane = ordered["lane"].to_numpy().astype(np.int64)
        for column in (self.ids, self.frame, self.lane, *self.values.values()):
            column.flags.writeable = False  # `at` hands out views of the values it does not interpolate
        self._starts = np.searchsorted(self.frame, np.arange(int(self.frame[-1]) + 2 if len(self.frame) else 1))
        """Each frame's first row (and the last frame's end): frame f is rows `_starts[f]` to `_starts[f + 1]`."""
        self._next = _next_rows(pd.factorize(ordered["vehicle_id"])[0], self.frame)
        """Each row's vehicle's (first) row in the next frame, -1 where it has none."""

    def _rows(self, frame: int) -> slice:
        if not 0 <= frame < len(self._starts) - 1:
            return slice(0, 0)
        return slice(int(self._starts[frame]), int(self._starts[frame + 1]))

    def at(self, time_s: float) -> SceneSnapshot:
        """The vehicles at `time_s` [s] (ids, values x_m, y_m, speed_mps, lane_position_m, heading_deg, length_m,
        width_m, and lanes): a frame's rows, or between two frames the earlier one's vehicles with their continuous
        values and heading interpolated toward the later frame (where they are in it)."""
        position = (time_s - self.origin_s) * self.rate_hz
        low = math.floor(position + _FRAME_TOLERANCE)
        share = position - low
        rows = self._rows(low)
        ids, lane = self.ids[rows], self.lane[rows]
        values = {name: column[rows] for name, column in self.values.items()}
        if share > _FRAME_TOLERANCE:
            following = self._next[rows]
            present = following >= 0
            source = following[present]
            for name in (*_CONTINUOUS, "heading_deg"):
                values[name] = values[name].copy()
            for name in _CONTINUOUS:
                values[name][present] += share * (self.values[name][source] - values[name][present])
            turn = (self.values["heading_deg"][source] - values["heading_deg"][present] + 180.0) % 360.0 - 180.0
            values["heading_deg"][present] = (values["heading_deg"][present] + share * turn) % 360.0
        return SceneSnapshot(ids, values, lane)


def _next_rows(vehicle: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """For rows of vehicle codes `vehicle` in frames `frame`: the first row of the same vehicle in the next frame,
    -1 where it has none."""
    order = np.lexsort((frame, vehicle))  # stable: the rows of one vehicle in one frame keep their order
    vehicle, frame = vehicle[order], frame[order]
    new = np.r_[True, (vehicle[1:] != vehicle[:-1]) | (frame[1:] != frame[:-1])]
    starts = np.flatnonzero(new)
    follows = (vehicle[starts[1:]] == vehicle[starts[:-1]]) & (frame[starts[1:]] == frame[starts[:-1]] + 1)
    following = np.r_[np.where(follows, order[starts[1:]], -1), -1]
    result = np.empty(len(order), dtype=np.int64)
    result[order] = following[np.cumsum(new) - 1]
    return result


def observe(config: Config, road: SceneRoad, ids: np.ndarray, values: dict[str, np.ndarray], lane: np.ndarray,
            ego: str, set_point_mps: float) -> np.ndarray:
    """The env's observation of vehicle `ego` among the vehicles `SceneFrames.at` gave, with cruise set-point
    `set_point_mps` [m/s]."""
    row = int(np.flatnonzero(ids == ego)[0])
    x, y = values["x_m"], values["y_m"]
    radius_m = config.lidar.range_m + CONTEXT_MARGIN_M
    near = np.hypot(x - x[row], y - y[row]) <= radius_m
    near[row] = False
    heading = np.radians(90.0 - values["heading_deg"])
    ego_lane = int(lane[row])
    offset = float(y[row]) - road.lane_y_m[ego_lane]  # SUMO places the front at the lateral offset from the lane
    position = float(values["lane_position_m"][row])
    state = EgoState(float(x[row]), float(y[row]), float(heading[row]), float(values["speed_mps"][row]), ego_lane,
                     position, offset, float(values["length_m"][row]), float(values["width_m"][row]), "",
                     RouteView(0, road.lanes - 1, (math.inf,) * road.lanes, math.inf, math.inf,
                               road.length_m - position))
    route = route_values(state, config.observation.route_range_m, config.scenario.lanes)
    return kernels.observation_vector(
        np.stack([x[near], y[near]], axis=1), heading[near], values["length_m"][near], values["width_m"][near],
        values["speed_mps"][near], values["lane_position_m"][near], lane[near], road.edge_rows, state.front_x,
        state.front_y, state.heading_rad, state.length_m, state.speed_mps, set_point_mps, position, ego_lane,
        state.changing_lane, config.lidar.beams, config.lidar.range_m, config.env.v_min_mps, config.env.v_max_mps,
        config.scenario.lanes, config.observation.lane_block == 1, config.observation.route_block == 1, *route)
