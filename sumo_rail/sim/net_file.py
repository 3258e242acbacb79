"""A SUMO network read from its file as a running SUMO gives it, for reading a recorded scene without a SUMO: the route
frame of a route (`road.RouteMap`, from the same lanes, lengths and links) and the road's outer edges the LIDAR sees
(`Sensing.road_edges` and `Sensing.junction_edges`, the same code on the file's shapes).

`NetFile` answers the few calls of SUMO's API those read (`lane.getIDList`, `getEdgeID`, `getLength`, `getLinks`,
`getShape`, `getWidth`; `edge.getIDList`, `getLaneNumber`; `junction.getIDList`, `getShape`, `getIncomingEdges`,
`getOutgoingEdges`) from the network's XML: a link is a `<connection>` (to lane, via lane), as SUMO loads it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from collections.abc import Iterable
from typing import Any

import numpy as np

from sumo_rail.sim.road import RouteMap
from sumo_rail.sim.sensing import Sensing

SUMO_LANE_WIDTH_M = 3.2
"""SUMO's lane width where the network names none [m]."""


def _points(shape: str) -> list[tuple[float, float]]:
    return [(float(x), float(y)) for x, y, *_ in (point.split(",") for point in shape.split())]


class _Lanes:
    """The lane calls, in SUMO's API names."""

    def __init__(self, root: ElementTree.Element) -> None:
        self.edge: dict[str, str] = {}
        self.length: dict[str, float] = {}
        self.width: dict[str, float] = {}
        self.shape: dict[str, list[tuple[float, float]]] = {}
        self.speed: dict[str, float] = {}
        for edge in root.iter("edge"):
            for lane in edge.iter("lane"):
                lane_id = lane.get("id", "")
                self.edge[lane_id] = edge.get("id", "")
                self.length[lane_id] = float(lane.get("length", "0"))
                self.width[lane_id] = float(lane.get("width", SUMO_LANE_WIDTH_M))
                self.shape[lane_id] = _points(lane.get("shape", ""))
                self.speed[lane_id] = float(lane.get("speed", "13.89"))
        self.links: dict[str, list[tuple[str, str]]] = {lane: [] for lane in self.edge}
        for connection in root.iter("connection"):
            source = f"{connection.get('from')}_{connection.get('fromLane')}"
            if source in self.links:
                self.links[source].append((f"{connection.get('to')}_{connection.get('toLane')}",
                                           connection.get("via", "")))

    def getIDList(self) -> list[str]:
        return list(self.edge)

    def getEdgeID(self, lane: str) -> str:
        return self.edge[lane]

    def getLength(self, lane: str) -> float:
        return self.length[lane]

    def getWidth(self, lane: str) -> float:
        return self.width[lane]

    def getShape(self, lane: str) -> list[tuple[float, float]]:
        return self.shape[lane]

    def getLinks(self, lane: str) -> list[tuple[str, bool, bool, bool, str]]:
        """(to lane, -, -, -, via lane) of each link, as SUMO's tuple holds them at 0 and 4."""
        return [(to, True, True, False, via) for to, via in self.links[lane]]


class _Edges:
    def __init__(self, root: ElementTree.Element) -> None:
        self.lanes = {edge.get("id", ""): len(edge.findall("lane")) for edge in root.iter("edge")}
        self.ends = {edge.get("id", ""): (edge.get("from", ""), edge.get("to", "")) for edge in root.iter("edge")
                     if edge.get("function") != "internal"}

    def getIDList(self) -> list[str]:
        return list(self.lanes)

    def getLaneNumber(self, edge: str) -> int:
        return self.lanes[edge]


class _Junctions:
    def __init__(self, root: ElementTree.Element, edges: _Edges) -> None:
        self.shape = {junction.get("id", ""): _points(junction.get("shape", "")) for junction in root.iter("junction")}
        self._edges = edges

    def getIDList(self) -> list[str]:
        return list(self.shape)

    def getShape(self, junction: str) -> list[tuple[float, float]]:
        return self.shape[junction]

    def getIncomingEdges(self, junction: str) -> list[str]:
        return [edge for edge, (_, to) in self._edges.ends.items() if to == junction]

    def getOutgoingEdges(self, junction: str) -> list[str]:
        return [edge for edge, (start, _) in self._edges.ends.items() if start == junction]


class NetFile(Sensing):
    """A network file's lanes, edges and junctions, answered as SUMO's API answers them (`root`: the file's root
    element)."""

    def __init__(self, root: ElementTree.Element) -> None:
        self.lane = _Lanes(root)
        self.edge = _Edges(root)
        self.junction = _Junctions(root, self.edge)
        self._api: Any = self

    def frame(self, route: tuple[str, ...], main_lanes: int) -> RouteMap:
        """The route frame of `route` (edge ids), as `Simulation.route_map` is built for it (`main_lanes`:
        scenario.lanes)."""
        return RouteMap.from_sumo(self, route, main_lanes)

    def successors(self) -> dict[str, set[str]]:
        """Each edge's successors: the edges its lanes lead onto (junctions crossed), internal edges left out."""
        successors: dict[str, set[str]] = {edge: set() for edge in self.edge.ends}
        for lane, links in self.lane.links.items():
            source = self.lane.edge[lane]
            if source in successors:
                successors[source].update(self.lane.edge[to] for to, _ in links if self.lane.edge[to] in successors)
        return successors

    def entries(self) -> list[str]:
        """The edges no edge leads into (all of them when every one has a predecessor), in id order."""
        successors = self.successors()
        entered = set().union(*successors.values())
        return sorted(edge for edge in successors if edge not in entered) or sorted(successors)

    def reaches(self, source: str, target: str) -> bool:
        """Whether edge `target` can be driven to from edge `source`."""
        successors, seen, queue = self.successors(), {source}, [source]
        while queue:
            for after in successors[queue.pop()] - seen:
                seen.add(after)
                queue.append(after)
        return target in seen

    def main_route(self) -> tuple[str, ...]:
        """The network's main road as a route: from the widest edge that no edge leads into (of all edges when
        every one has a predecessor), on along the widest successor at each junction (then the lowest id) until the
        road ends or comes back on itself."""
        successors = self.successors()
        starts = self.entries()
        widest = self.edge.lanes.get

        def pick(edges: Iterable[str]) -> str | None:
            return min(edges, key=lambda edge: (-widest(edge, 0), edge), default=None)

        route, edge = [], pick(starts)
        while edge is not None and edge not in route:
            route.append(edge)
            edge = pick(successors[edge])
        return tuple(route)

    def outer_edges(self) -> np.ndarray:
        """The road's outer edges as segments (S, 2, 2) [m], the edges' sides then the junctions', as the env's LIDAR
        sees them (`ego.edge_rows`)."""
        return np.concatenate([self.road_edges(), self.junction_edges()])
