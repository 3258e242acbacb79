"""The env's observation computed from a recorded scene: what the ego of a track would have seen at an instant.

The env observes an ego through one SUMO context subscription (every vehicle whose front is within the LIDAR range
plus `ego.CONTEXT_MARGIN_M` of the ego's front, in the order of their ids) and hands their front bumpers, headings,
speeds, sizes, positions along the road and lanes, the road's edge boxes and the ego's own state to
`kernels.observation_vector`. Here the same function gets the scene's vehicles at the instant (linearly interpolated
between frames when the instant falls between two), the edge boxes of the scene's road (its edges' outer sides and its
junctions' walls, as `Sensing` draws them from SUMO, read from the network file by `sim.net_file`), positions and lanes
in the route frame of the ego's recorded edges (`sim.road.RouteMap`, as the env builds it for a seated ego) and the
route block from that frame (`route_values`). Any SUMO network: several edges, bends, ramps, lane drops. What a track
cannot give, the ego's cruise set-point, is an input (`actions.speed_reading` estimates it).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError
from sumo_rail.recordings.road import network_root
from sumo_rail.recordings.trajectory import SceneSnapshot, TrajectoryPoint
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.net_file import NetFile
from sumo_rail.sim.road import UNPLACED, RouteMap
from sumo_rail.sim.route_progress import route_values
from sumo_rail.sim.vehicles import EgoState

_FRAME_TOLERANCE = 1e-6
"""An instant within this share of a frame of a frame is that frame."""
_CONTINUOUS = ("x_m", "y_m", "speed_mps", "lane_position_m")


@dataclass(frozen=True)
class SceneRoad:
    """A scene's road on its SUMO network (`net`): the main road's route (`NetFile.main_route`, the scene env's
    scenario.route), its lanes (the route's widest edge's), the edge boxes the LIDAR sees ((S, 6) rows of centre x, y,
    axis x, y, half length, half width, as `ego.edge_rows`) and its speed limit [m/s] (the fastest lane along the
    route)."""

    net: NetFile
    route: tuple[str, ...]
    lanes: int
    edge_rows: np.ndarray
    speed_limit_mps: float
    _frames: dict[tuple[str, ...], RouteMap] = field(default_factory=dict, compare=False, repr=False)

    def frame(self, route: tuple[str, ...]) -> RouteMap:
        """The route frame of a vehicle driving `route` (its recorded edges), as the env builds it for the ego."""
        found = self._frames.get(route)
        if found is None:
            found = self._frames[route] = self.net.frame(route, self.lanes)
        return found

    def sideways_sign(self, route: tuple[str, ...]) -> float | None:
        """What y is to a vehicle driving `route` when the route is one edge straight along x: its sideways position
        [m], left positive (1.0: along +x, as highD's and NGSIM's roads; -1.0: along -x, highD's other carriageway,
        whose left is -y); None on any other route (a lane change is then read at its crossing)."""
        shapes = [np.asarray(self.net.lane.getShape(lane)) for lane in self.net.lane.getIDList()
                  if len(route) == 1 and self.net.lane.getEdgeID(lane) == route[0]]
        if not shapes or any(len(shape) < 2 or np.ptp(shape[:, 1]) > 1e-6 for shape in shapes):
            return None
        signs = {float(np.sign(shape[-1, 0] - shape[0, 0])) for shape in shapes}
        return signs.pop() if len(signs) == 1 and 0.0 not in signs else None

    def place(self, route: tuple[str, ...], edges: np.ndarray, lanes: np.ndarray,
              lane_positions_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions along `route` [m] and route lanes of vehicles on `edges`' lanes `lanes` at `lane_positions_m`
        [m] (`RouteMap.place`; a lane not linked to the route is `road.UNPLACED`)."""
        starts, route_lanes = self.lane_starts(route, [f"{edge}_{lane}" for edge, lane in zip(edges, lanes,
                                                                                                 strict=True)])
        return starts + lane_positions_m, route_lanes

    def lane_starts(self, route: tuple[str, ...], lane_ids: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """Where each lane of `lane_ids` starts along `route` [m] and its route lane (`RouteMap.lane_places`; a lane
        not linked to the route is `road.UNPLACED`)."""
        places = self.frame(route).lane_places
        starts, route_lanes = zip(*[places.get(lane_id, UNPLACED) for lane_id in lane_ids],
                                  strict=True) if len(lane_ids) else ((), ())
        return np.asarray(starts, dtype=np.float64), np.asarray(route_lanes, dtype=np.int64)

    def lateral_offset_m(self, lane_id: str, x_m: float, y_m: float) -> float:
        """Signed distance [m] of the point (x, y) from lane `lane_id`'s centre line, left positive (SUMO's lateral
        position of a vehicle's front)."""
        shape = np.asarray(self.net.lane.getShape(lane_id), dtype=np.float64)
        point = np.array([x_m, y_m])
        best, offset = math.inf, 0.0
        for start, end in itertools.pairwise(shape):
            along = end - start
            length = math.hypot(float(along[0]), float(along[1]))
            unit = along / max(length, 1e-12)
            relative = point - start
            t = min(max(float(relative @ unit), 0.0), length)
            distance = float(np.linalg.norm(relative - t * unit))
            if distance < best:
                best, offset = distance, float(unit[0] * relative[1] - unit[1] * relative[0])
        return offset


def scene_routes(tracks: pd.DataFrame) -> dict[str, tuple[str, ...]]:
    """The route each vehicle of `tracks` (rows of `scene.TRACK_COLUMNS`) drove: its edges in the order it drove
    them, junctions left out."""
    ordered = tracks.sort_values(["vehicle_id", "time_s"], kind="stable")
    edges, ids = ordered["edge"].to_numpy().astype(str), ordered["vehicle_id"].to_numpy().astype(str)
    kept = ~np.char.startswith(edges, ":")
    edges, ids = edges[kept], ids[kept]
    entered = np.ones(len(edges), dtype=bool)
    entered[1:] = (edges[1:] != edges[:-1]) | (ids[1:] != ids[:-1])
    routes = pd.Series(edges[entered]).groupby(ids[entered], sort=False).agg(tuple)
    return {str(vehicle): tuple(route) for vehicle, route in routes.items()}


def in_route_frame(road: SceneRoad, track: pd.DataFrame, route: tuple[str, ...]) -> pd.DataFrame:
    """One vehicle's rows with lane and lane_position_m in the route frame of `route` (its recorded edges: route
    lanes, positions along the route [m], as the env's ego on that route sees itself) and edge the route's first on
    every row, so that the lane index is compared across edges (a change of edge is no lane change, a lane kept
    where lanes are added or dropped keeps its route lane)."""
    positions, lanes = road.place(route, track["edge"].to_numpy(), track["lane"].to_numpy(),
                                  track["lane_position_m"].to_numpy())
    return track.assign(lane=lanes, lane_position_m=positions, edge=route[0])


def route_point(road: SceneRoad, route: tuple[str, ...], snapshot: SceneSnapshot, row: int,
                time_s: float) -> TrajectoryPoint:
    """Entry `row` of `snapshot` as the trajectory point at `time_s` [s], its lane and position in the route frame of
    `route` (as the env's ego on that route reads its own)."""
    rows = slice(row, row + 1)
    positions, lanes = road.place(route, snapshot.values["edge"][rows], snapshot.lanes[rows],
                                  snapshot.values["lane_position_m"][rows])
    return snapshot.point(row, time_s)._replace(lane=int(lanes[0]), lane_position_m=float(positions[0]))


def in_frame(road: SceneRoad, route: tuple[str, ...], snapshot: SceneSnapshot) -> SceneSnapshot:
    """`snapshot` with every vehicle's lane and lane_position_m in the route frame of `route` (a vehicle on a lane
    not linked to it at position -inf, in no lane of it), so that leaders are found across edges."""
    positions, lanes = road.place(route, snapshot.values["edge"], snapshot.lanes, snapshot.values["lane_position_m"])
    return SceneSnapshot(snapshot.ids, {**snapshot.values, "lane_position_m": positions}, lanes)


def route_from(route: tuple[str, ...], edge: str) -> tuple[str, ...]:
    """The rest of `route` from `edge` on (the seat's route, as the replay gives the seated ego); all of it from a
    junction."""
    return route[route.index(edge):] if edge in route else route


def scene_road(net_file: Path) -> SceneRoad:
    """The road of a scene's network, any SUMO network: several edges, bends, ramps and lane drops; DatasetError
    naming the file when it is not a SUMO network with an edge."""
    net = NetFile(network_root(net_file))
    route = net.main_route()
    if not route:
        raise DatasetError(f"network {net_file} has no edge; a scene's road is a SUMO network")
    lanes = [lane for edge in route for lane in net.lane.getIDList() if net.lane.getEdgeID(lane) == edge]
    boxes = lidar.edge_boxes(net.outer_edges())
    return SceneRoad(net, route, max(net.edge.getLaneNumber(edge) for edge in route),
                     np.hstack([boxes.centre_xy, boxes.axis_xy, boxes.half_size_m]),
                     max(net.lane.speed[lane] for lane in lanes))


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
        self.values["edge"] = ordered["edge"].to_numpy().astype(str)
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
        width_m and edge (the edge id), and lanes): a frame's rows, or between two frames the earlier one's vehicles
        with their continuous values and heading interpolated toward the later frame (where they are in it)."""
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
            ego: str, set_point_mps: float, route: tuple[str, ...] | None = None) -> np.ndarray:
    """The env's observation of vehicle `ego` among the vehicles `SceneFrames.at` gave, with cruise set-point
    `set_point_mps` [m/s], in the route frame of `route` (the ego's recorded edges; None: the road's main route),
    as the env observes a seated ego on that route."""
    row = int(np.flatnonzero(ids == ego)[0])
    x, y = values["x_m"], values["y_m"]
    radius_m = config.lidar.range_m + CONTEXT_MARGIN_M
    near = np.hypot(x - x[row], y - y[row]) <= radius_m
    near[row] = False
    heading = np.radians(90.0 - values["heading_deg"])
    route = road.route if route is None else route
    seen = np.flatnonzero(near)
    positions, lanes = road.place(route, values["edge"][seen], lane[seen], values["lane_position_m"][seen])
    (position,), (ego_lane,) = road.place(route, values["edge"][row:row + 1], lane[row:row + 1],
                                          values["lane_position_m"][row:row + 1])
    lane_id = f"{values['edge'][row]}_{lane[row]}"
    position = float(position)
    state = EgoState(float(x[row]), float(y[row]), float(heading[row]), float(values["speed_mps"][row]),
                     int(ego_lane), position, road.lateral_offset_m(lane_id, float(x[row]), float(y[row])),
                     float(values["length_m"][row]), float(values["width_m"][row]), lane_id,
                     road.frame(route).view(lane_id, position))
    config_route = route_values(state, config.observation.route_range_m, config.scenario.lanes)
    return kernels.observation_vector(
        np.stack([x[near], y[near]], axis=1), heading[near], values["length_m"][near], values["width_m"][near],
        values["speed_mps"][near], positions, lanes, road.edge_rows, state.front_x,
        state.front_y, state.heading_rad, state.length_m, state.speed_mps, set_point_mps, position, state.lane,
        state.changing_lane, config.lidar.beams, config.lidar.range_m, config.env.v_min_mps, config.env.v_max_mps,
        config.scenario.lanes, config.observation.lane_block == 1, config.observation.route_block == 1,
        *config_route)
