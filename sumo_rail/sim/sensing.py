"""Reading the road and the vehicles around an ego, in the ego's route frame (`sumo_rail.sim.road`)."""

from __future__ import annotations

import math
import operator
import struct
from typing import Any

import numpy as np

from sumo_rail.sim import network
from sumo_rail.sim.junction_walls import junction_walls
from sumo_rail.sim.road import UNPLACED, RouteMap
from sumo_rail.sim.sumo_api import EGO_ID, DecisionCalls
from sumo_rail.sim.vehicles import EgoState, Neighbours


class Sensing:
    """The reading part of `Simulation` (a mixin: `_api`, `_calls`, `_constants`, `context_radius_m` and `route_map`
    are the simulation's)."""

    _api: Any
    _calls: DecisionCalls
    _client: Any
    _constants: Any
    context_radius_m: float
    route_map: RouteMap

    def _context_setup(self) -> None:
        tc = self._constants
        variables = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_LANEPOSITION, tc.VAR_LANE_ID)
        self._context_fields = operator.itemgetter(*variables)
        # libsumo's own vector type: a tuple would be converted to one at every subscription
        int_vector = getattr(self._client, "IntVector", None)
        self._context_variables = variables if int_vector is None else int_vector(variables)
        self._row_packers: dict[int, struct.Struct] = {}
        """Neighbours -> the packer of their rows (8 float64 each, `observe`)."""
        self._sizes: dict[str, tuple[float, float]] = {}
        """Vehicle id -> (length, width) [m], read once per vehicle (`forget_sizes` when ids may be reused)."""

    def forget_sizes(self, vehicle: str | None = None) -> None:
        """Drop the cached size of `vehicle` (a vehicle added under an id used before), or of every vehicle (None:
        after a load, where ids start again)."""
        if vehicle is None:
            self._sizes.clear()
        else:
            self._sizes.pop(vehicle, None)

    def _size(self, vehicle: str) -> tuple[float, float]:
        """(length, width) [m] of `vehicle`, from SUMO the first time it is asked."""
        size = self._sizes[vehicle] = (self._api.vehicle.getLength(vehicle), self._api.vehicle.getWidth(vehicle))
        return size

    def observe(self, vehicle: str = EGO_ID) -> tuple[EgoState, Neighbours]:
        """An ego and its neighbours (other egos included) within the context radius, from one context
        subscription. Positions along the road and lanes are the route frame's (`RouteMap.place`); the ego's state
        carries its route view.

        Headings are SUMO's angles (degrees, 0 = north, clockwise) as math headings (radians, 0 = +x,
        counter-clockwise): radians(90 - angle). The subscription is made and dropped at each decision: SUMO
        answers a new subscription at once, and a standing one would be recomputed at every step of the decision
        period for nothing. Lengths and widths, fixed per vehicle, are read once per vehicle (`_sizes`), not in the
        subscription: SUMO evaluates every subscribed variable of every vehicle in range at each decision.
        """
        fields, place, sizes, calls = self._context_fields, self.route_map.place, self._sizes, self._calls
        domain, radius_m = self._constants.CMD_GET_VEHICLE_VARIABLE, self.context_radius_m
        calls.subscribe_context(vehicle, domain, radius_m, self._context_variables)
        results = calls.context_results(vehicle)
        calls.unsubscribe_context(vehicle, domain, radius_m)
        (ego_x, ego_y), angle, speed, lane_position, lane_id = fields(results.pop(vehicle))
        length, width = sizes.get(vehicle) or self._size(vehicle)
        position_m, lane = place(lane_id, lane_position)
        ego_state = EgoState(ego_x, ego_y, math.radians(90.0 - angle), speed, lane, position_m,
                             calls.lateral_position(vehicle), length, width, lane_id,
                             self.route_map.view(lane_id, position_m))
        flat: list[float] = []
        extend, radians, lane_places = flat.extend, math.radians, self.route_map.lane_places.get
        for other, variables in results.items():
            (x, y), angle, speed, lane_position, lane_id = fields(variables)
            length, width = sizes.get(other) or self._size(other)
            start_m, lane = lane_places(lane_id, UNPLACED)  # `place`, inlined: it runs for every neighbour
            extend((x, y, radians(90.0 - angle), speed, start_m + lane_position, length, width, lane))
        rows = np.empty((len(results), 8))
        self._rows_packer(len(results)).pack_into(rows, 0, *flat)  # type: ignore[arg-type]  # an ndarray is a buffer
        # ids, front_xy, heading_rad, speed_mps, lane_position_m, length_m, width_m, lane: positional arguments,
        # as for the ego's state, cost a third of keyword ones
        neighbours = Neighbours(tuple(results), rows[:, :2], rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 6],
                                rows[:, 7].astype(np.int64))
        return ego_state, neighbours

    def _rows_packer(self, count: int) -> struct.Struct:
        """The packer of `count` neighbours' rows (native float64, as numpy's arrays hold them)."""
        packer = self._row_packers.get(count)
        if packer is None:
            packer = self._row_packers[count] = struct.Struct(f"={8 * count}d")
        return packer

    def leader_speed_mps(self, vehicle: str, range_m: float) -> float:
        """The speed [m/s] of SUMO's leader of `vehicle` (its car following's, along its route) within `range_m` [m]
        ahead; inf when there is none."""
        found = self._api.vehicle.getLeader(vehicle, range_m)
        return float(self._api.vehicle.getSpeed(found[0])) if found else math.inf

    def vehicle_types(self, ids: tuple[str, ...]) -> list[str]:
        """SUMO vehicle type of each vehicle in `ids` (e.g. "car", "truck"), for drawing; "" for one that has left
        SUMO since it was seen (a frame of the ego's last decision before a collision removed both, or the end of the
        road)."""
        get_type, unknown = self._api.vehicle.getTypeID, self._client.TraCIException
        types = []
        for vehicle in ids:
            try:
                types.append(get_type(vehicle))
            except unknown:
                types.append("")
        return types

    def lane_shapes(self) -> list[tuple[np.ndarray, float, bool]]:
        """Every lane of the network, junctions' included, for drawing: its centre line [m], its width [m] and
        whether it is its edge's rightmost or leftmost lane (an outer edge of the road)."""
        lane, edge = self._api.lane, self._api.edge
        shapes = []
        for lane_id in lane.getIDList():
            edge_id, _, index = lane_id.rpartition("_")
            outer = not edge_id.startswith(":") and int(index) in (0, edge.getLaneNumber(edge_id) - 1)
            shapes.append((np.array(lane.getShape(lane_id)), lane.getWidth(lane_id), outer))
        return shapes

    def road_edges(self) -> np.ndarray:
        """The road's outer edges as line segments [m], shape (S, 2, 2): the right edges of the network's edges first,
        then their left edges (each edge's rightmost and leftmost lane's outer side)."""
        sides = [self._edge_sides(edge_id) for edge_id in self._api.edge.getIDList() if not edge_id.startswith(":")]
        return np.concatenate([network.segments(right) for right, _ in sides]
                              + [network.segments(left) for _, left in sides])

    def junction_edges(self) -> np.ndarray:
        """The road's outer edges across its junctions (`sumo_rail.sim.junction_walls`) as line segments [m], shape
        (S, 2, 2); none on the straight road."""
        junction = self._api.junction
        walls = [np.empty((0, 2, 2))]
        for junction_id in [junction_id for junction_id in junction.getIDList() if not junction_id.startswith(":")]:
            incoming = [edge for edge in junction.getIncomingEdges(junction_id) if not edge.startswith(":")]
            outgoing = [edge for edge in junction.getOutgoingEdges(junction_id) if not edge.startswith(":")]
            if incoming and outgoing:
                mouths = [np.array([right[end], left[end]]) for edges, end in ((incoming, -1), (outgoing, 0))
                          for right, left in map(self._edge_sides, edges)]
                walls.append(junction_walls(np.array(junction.getShape(junction_id)), mouths))
        return np.concatenate(walls)

    def _edge_sides(self, edge_id: str) -> tuple[np.ndarray, np.ndarray]:
        """An edge's right and left outer sides (its rightmost and leftmost lane's outer side) as polylines [m]."""
        lane = self._api.lane
        right_id, left_id = f"{edge_id}_0", f"{edge_id}_{self._api.edge.getLaneNumber(edge_id) - 1}"
        return (network.offset_polyline(np.array(lane.getShape(right_id)), -lane.getWidth(right_id) / 2),
                network.offset_polyline(np.array(lane.getShape(left_id)), lane.getWidth(left_id) / 2))

