"""The ego's route as a frame every vehicle is placed in: a position along the route and a route lane.

SUMO numbers lanes per edge and measures positions per lane. Where a road has several edges (a ramp joins, lanes
end, an exit leaves), vehicles on different edges are compared in the route frame, built once per network from SUMO's
own lane links (`RouteMap.from_sumo`):
- position [m]: distance along the ego's route from its first edge's start, for every lane linked to the route
  (on-ramps upstream of a joint, off-ramps and the roads they lead to downstream): start of its edge + its lane
  position;
- route lane: lanes keep their place from the left along links (the link from an edge's leftmost linked lane fixes the
  next edge's numbering), numbered so that the route's leftmost lane is `lanes - 1` and the rightmost lane of the main
  road 0; an acceleration lane, an on-ramp or an off-ramp right of it is -1.
On the straight road (one edge), positions are SUMO's lane positions and route lanes SUMO's lane indices, exactly.

What the ego knows of its route (`RouteView`, the navigation a driver has) comes from the same links: how far ahead
each lane of its edge stops leading along the route, and the next merge (a road joins the route) and diverge (the
road branches off it).
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections import deque
from dataclasses import dataclass
from typing import Any, NamedTuple

from sumo_rail.sim.records import quick_init

UNPLACED = (-math.inf, -1000)
"""(position, route lane) of a lane not linked to the route (another road of the network)."""


@quick_init
@dataclass(frozen=True)
class RouteView:
    """The ego's route from where it is. Distances from the ego's front [m], inf where nothing comes."""

    lowest_lane: int
    """Route lanes of the ego's edge, lowest_lane..highest_lane."""
    highest_lane: int
    lane_end_m: tuple[float, ...]
    """For each lane of the ego's edge, from the lowest: how far it leads along the route (inf: to the route's end)."""
    merge_ahead_m: float
    """Distance to the next point where another road joins the route."""
    diverge_ahead_m: float
    """Distance to the next point where the road branches off the route (an exit, or the ego's own exit)."""
    route_left_m: float
    """Distance to the end of the route."""

    def lane_end(self, lane: int) -> float:
        """How far route lane `lane` leads along the route from the ego's position (0 where it is not on this edge)."""
        return self.lane_end_m[lane - self.lowest_lane] if self.lowest_lane <= lane <= self.highest_lane else 0.0

    def best_lane_offset(self, lane: int) -> int:
        """Lanes to move (positive = left) to the nearest lane that leads farthest along the route; 0 in such a lane."""
        ends = self.lane_end_m
        farthest = max(ends)
        if self.lane_end(lane) >= farthest:
            return 0
        best = 0
        for index, end in enumerate(ends):  # offsets rise: of two as near, the one to the right comes first
            offset = self.lowest_lane + index - lane
            if end >= farthest and (not best or abs(offset) < abs(best)):
                best = offset
        return best


@dataclass
class _Edge:
    start_m: float
    lane_offset: int
    lanes: int
    length_m: float


class RouteMap:
    """The route frame of one network and ego route (see the module's docstring)."""

    def __init__(self, route: tuple[str, ...], edges: dict[str, _Edge], lane_places: dict[str, tuple[float, int]],
                 lane_ends: dict[str, float], merges_m: list[float], diverges_m: list[float], length_m: float) -> None:
        self.route = route
        self._edges = edges
        self.lane_places = lane_places
        """Lane id -> (its start's position along the route [m], its route lane); internal lanes included."""
        self._lane_ends = lane_ends
        self.merges_m = merges_m
        self.diverges_m = diverges_m
        self.length_m = length_m
        """Length of the route [m]."""
        self._merges_sorted, self._diverges_sorted = sorted(merges_m), sorted(diverges_m)
        self._view_lanes: dict[str, tuple[int, int, tuple[str, ...]]] = {}

    @classmethod
    def from_sumo(cls, api: Any, route: tuple[str, ...], main_lanes: int) -> RouteMap:
        """Build the frame from a running SUMO (`api`: libsumo or a traci connection) for the ego's `route`."""
        lanes = list(api.lane.getIDList())
        edge_of = {lane: api.lane.getEdgeID(lane) for lane in lanes}
        length = {lane: api.lane.getLength(lane) for lane in lanes}
        links: dict[str, list[tuple[str, str]]] = {lane: [(link[0], link[4]) for link in api.lane.getLinks(lane)]
                                                   for lane in lanes}
        edges: dict[str, _Edge] = {}
        for lane in lanes:
            edge = edge_of[lane]
            if not edge.startswith(":") and edge not in edges:
                edges[edge] = _Edge(0.0, 0, api.edge.getLaneNumber(edge), length[f"{edge}_0"])
        _place_edges(route, edges, edge_of, links, length)
        shift = main_lanes - 1 - max(edges[edge].lane_offset + edges[edge].lanes - 1 for edge in route)
        places: dict[str, tuple[float, int]] = {}
        for edge_id, edge in edges.items():
            if math.isfinite(edge.start_m):
                edge.lane_offset += shift
                for index in range(edge.lanes):
                    places[f"{edge_id}_{index}"] = (edge.start_m, edge.lane_offset + index)
        _place_internal_lanes(places, edge_of, links, length)
        ends = _lane_ends(route, edges, links)
        on_route = set(route)
        merges, diverges = [], []
        for source, target in itertools.pairwise(route):
            outside = {edge_of[lane] for lane in lanes if edge_of[lane] not in on_route and not
                       edge_of[lane].startswith(":") and any(edge_of[to] == target for to, _ in links[lane])}
            if outside:
                merges.append(edges[target].start_m)
            branches = {edge_of[to] for index in range(edges[source].lanes) for to, _ in links[f"{source}_{index}"]}
            if branches - on_route:
                diverges.append(edges[source].start_m + edges[source].length_m)
        last = edges[route[-1]]
        return cls(route, edges, places, ends, merges, diverges, last.start_m + last.length_m)

    @property
    def single_edge(self) -> bool:
        """The route is one edge whose lanes are numbered as SUMO numbers them (the straight road)."""
        return len(self.route) == 1 and self._edges[self.route[0]].lane_offset == 0

    def place(self, lane_id: str, lane_position_m: float) -> tuple[float, int]:
        """(position along the route [m], route lane) of a vehicle in `lane_id` at `lane_position_m`; `UNPLACED` for a
        lane not linked to the route."""
        start_m, lane = self.lane_places.get(lane_id, UNPLACED)
        return start_m + lane_position_m, lane

    def edge_lanes(self, lane_id: str) -> tuple[int, int]:
        """The lowest and highest route lane of the edge of `lane_id` (an internal lane: its own route lane only)."""
        edge = self._edges.get(lane_id.rpartition("_")[0])
        if edge is None:
            lane = self.lane_places.get(lane_id, UNPLACED)[1]
            return lane, lane
        return edge.lane_offset, edge.lane_offset + edge.lanes - 1

    def sumo_lane(self, lane_id: str, route_lane: int) -> int:
        """SUMO's index, on the edge of `lane_id`, of route lane `route_lane`."""
        return route_lane - self.edge_lanes(lane_id)[0]

    def view(self, lane_id: str, position_m: float) -> RouteView:
        """The route from an ego in `lane_id` whose front is at `position_m` along the route."""
        lanes = self._view_lanes.get(lane_id)
        if lanes is None:
            lanes = self._view_lanes[lane_id] = self._lanes_beside(lane_id)
        lowest, highest, ids = lanes
        ends = self._lane_ends
        lane_end = tuple([ends.get(lane, position_m) - position_m for lane in ids])
        # the nearest point ahead: the first of the sorted points past the ego (subtracting keeps their order)
        return RouteView(lowest, highest, lane_end, _next_after(self._merges_sorted, position_m),
                         _next_after(self._diverges_sorted, position_m), self.length_m - position_m)

    def _lanes_beside(self, lane_id: str) -> tuple[int, int, tuple[str, ...]]:
        """The route lanes of the edge of `lane_id`, lowest and highest, and the ids of its lanes (an internal lane:
        itself), which `view` reads for every lane id once."""
        lowest, highest = self.edge_lanes(lane_id)
        edge = lane_id.rpartition("_")[0]
        ids = tuple(f"{edge}_{index}" for index in range(highest - lowest + 1)) if edge in self._edges else (lane_id,)
        return lowest, highest, ids


def _next_after(points_m: list[float], position_m: float) -> float:
    """Distance [m] from `position_m` to the first of the sorted `points_m` beyond it; inf when none is."""
    index = bisect.bisect_right(points_m, position_m)
    return points_m[index] - position_m if index < len(points_m) else math.inf


class _Joint(NamedTuple):
    """A link between an edge being placed from ("here") and a neighbouring edge ("other")."""

    other: str
    here_lane: int
    other_lane: int
    junction_m: float
    """Length of the junction's internal lanes between them [m]."""
    upstream: bool
    """The other edge leads into this one."""


def _place_edges(route: tuple[str, ...], edges: dict[str, _Edge], edge_of: dict[str, str],
                 links: dict[str, list[tuple[str, str]]], length: dict[str, float]) -> None:
    """Set every linked edge's start [m] and raw lane offset: outward from the route's first edge along links both
    ways, breadth first, the route's edges before others; unlinked edges keep start -inf."""
    for edge in edges.values():
        edge.start_m = -math.inf
    edges[route[0]].start_m = 0.0
    incoming: dict[str, list[_Joint]] = {}
    for lane, outgoing in links.items():
        if edge_of[lane].startswith(":"):
            continue
        for to, via in outgoing:
            joint = _Joint(edge_of[lane], from_lane_index(to), from_lane_index(lane), _via_length(via, length, links),
                           True)
            incoming.setdefault(edge_of[to], []).append(joint)
    rank = {edge: position for position, edge in enumerate(route)}
    placed, queue = {route[0]}, deque(route[:1])
    while queue:
        here_id = queue.popleft()
        here = edges[here_id]
        joints = incoming.get(here_id, []) + [
            _Joint(edge_of[to], index, from_lane_index(to), _via_length(via, length, links), False)
            for index in range(here.lanes) for to, via in links[f"{here_id}_{index}"] if not to.startswith(":")]
        leftmost: dict[str, _Joint] = {}
        for joint in joints:  # lanes keep their place from the left: the leftmost link fixes the numbering
            if joint.other not in leftmost or joint.here_lane > leftmost[joint.other].here_lane:
                leftmost[joint.other] = joint
        for joint in sorted(leftmost.values(), key=lambda joint: rank.get(joint.other, len(rank))):
            if joint.other in placed:
                continue
            other = edges[joint.other]
            other.start_m = (here.start_m - joint.junction_m - other.length_m if joint.upstream
                             else here.start_m + here.length_m + joint.junction_m)
            other.lane_offset = here.lane_offset + joint.here_lane - joint.other_lane
            placed.add(joint.other)
            queue.append(joint.other)


def _junction_lanes(via: str, links: dict[str, list[tuple[str, str]]]) -> list[str]:
    """The chain of internal (junction) lanes a link runs through, from its first one `via` ("" for a direct link)."""
    chain = []
    while via.startswith(":") and via not in chain:
        chain.append(via)
        following = links.get(via, [])
        via = following[0][0] if following else ""
    return chain


def _via_length(via: str, length: dict[str, float], links: dict[str, list[tuple[str, str]]]) -> float:
    """Length of the junction a link runs through [m] (0 for a direct link)."""
    return sum(length[lane] for lane in _junction_lanes(via, links))


def _place_internal_lanes(places: dict[str, tuple[float, int]], edge_of: dict[str, str],
                          links: dict[str, list[tuple[str, str]]], length: dict[str, float]) -> None:
    """Internal (junction) lanes start where the lane they leave ends, in its route lane."""
    for lane, outgoing in list(links.items()):
        if edge_of[lane].startswith(":") or lane not in places:
            continue
        start_m, route_lane = places[lane]
        for _, via in outgoing:
            end_m = start_m + length[lane]
            for internal in _junction_lanes(via, links):
                places.setdefault(internal, (end_m, route_lane))
                end_m += length[internal]


def _lane_ends(route: tuple[str, ...], edges: dict[str, _Edge], links: dict[str, list[tuple[str, str]]]
               ) -> dict[str, float]:
    """For each lane of the route's edges (and the junction lanes it leads into), the position [m] where following
    it along the route ends: inf where it reaches the route's end."""
    ends: dict[str, float] = {}
    last = route[-1]
    for index in range(edges[last].lanes):
        ends[f"{last}_{index}"] = math.inf
    for source, target in zip(reversed(route[:-1]), reversed(route[1:]), strict=True):
        edge = edges[source]
        end_of_edge = edge.start_m + edge.length_m
        for index in range(edge.lanes):
            lane = f"{source}_{index}"
            reach = [(ends.get(to, end_of_edge), via) for to, via in links[lane] if to.rpartition("_")[0] == target]
            ends[lane] = max((end for end, _ in reach), default=end_of_edge)
            for end, via in reach:
                for internal in _junction_lanes(via, links):
                    ends[internal] = max(ends.get(internal, end), end)
    return ends


def from_lane_index(lane_id: str) -> int:
    """SUMO's lane index in a lane id (EDGE_INDEX)."""
    return int(lane_id.rpartition("_")[2])
