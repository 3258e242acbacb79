"""The plain-XML of each road (`ScenarioConfig.kind`) after the scenario's settings are applied, ready for netconvert.

Every generated road is a main road along +x whose lanes spread to the right of y = 0 (so its left edge is straight
and lanes are added or dropped on the right), with its feature at `scenario.feature_at_m`:
- straight: one edge `highway` (the paper's road; its sources and files are exactly those of earlier versions);
- merge / merge_from_ramp: `main_in`, then `merge` with one lane more on the right (the acceleration lane,
  `scenario.feature_length_m` long) into which the one-lane `ramp` runs, then `main_out`; the ego drives the main
  road (merge) or starts on the ramp and must merge before the acceleration lane ends (merge_from_ramp);
- lane_drop: `main_in`, the work zone `zone` where the rightmost `scenario.dropped_lanes` lanes have ended, `main_out`
  where they open again;
- exit: `main_in`, then `main_out` and the one-lane `off_ramp`, reached from the rightmost lane only; the ego's route
  takes the exit.
Lanes keep their place from the left across the joints (connections are generated, netconvert builds the rest).
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path

from sumo_rail.config import ConfigError, ScenarioConfig

VEHICLE_TYPES_FILE = "traffic.rou.xml"
"""The straight road's routes file, whose vehicle types every road uses."""
EGO_TYPE = "ego"
ACCELERATION_EGO_TYPE = "ego_acceleration"
"""The ego's vehicle type under the acceleration interface (networks/traffic.rou.xml: Krauss without dawdling)."""
RAMP_OFFSET_M = 60.0
"""How far right of the main road's right edge the on-ramp starts and the off-ramp ends [m]."""
EXIT_RAMP_M = 400.0
"""Length of the off-ramp along x [m]."""


Shape = Callable[[ScenarioConfig, ElementTree.Element, ElementTree.Element, ElementTree.Element], dict[str, float]]
"""A road's feature: applies the scenario to the nodes and edges, adds the connections; the flows of its routes
[veh/h]."""


@dataclass(frozen=True)
class KindSources:
    """What a road kind is built from: its source files' stem, the ego's route in its routes file, its network file's
    stem, and the `Shape` of its feature (None: a road of one edge with netconvert's own connections and the traffic
    file's flow, no routes file of its own)."""

    stem: str
    ego_route_id: str
    net_stem: str
    shape: Shape | None


@dataclass(frozen=True)
class RoadSources:
    """One road's plain-XML, with the scenario's settings applied."""

    nodes: bytes
    edges: bytes
    connections: bytes | None
    """None: netconvert's own connections (the straight road)."""
    routes: bytes
    """The routes file: vehicle types, the routes (the ego's among them) and the background flows."""
    ego_route: tuple[str, ...]
    """The ego's edges, in order."""

    @property
    def files(self) -> dict[str, bytes]:
        """Every source as a file name and its bytes (what the cache key hashes)."""
        named = {"nodes": self.nodes, "edges": self.edges, "routes": self.routes}
        return named | ({"connections": self.connections} if self.connections is not None else {})


def source_names(kind: str) -> tuple[str, ...]:
    """The shipped files a generated road kind reads."""
    sources = KIND_SOURCES[kind]
    routes = (f"{sources.stem}.rou.xml",) if sources.shape is not None else ()
    return (f"{sources.stem}.nod.xml", f"{sources.stem}.edg.xml", *routes, VEHICLE_TYPES_FILE)


def road_sources(scenario: ScenarioConfig, sources: dict[str, bytes]) -> RoadSources:
    """The plain-XML of a generated road (`scenario.kind` other than network), from the shipped `sources` (file
    name -> bytes, `source_names`)."""
    kind = KIND_SOURCES[scenario.kind]
    nodes = ElementTree.fromstring(sources[f"{kind.stem}.nod.xml"])
    edges = ElementTree.fromstring(sources[f"{kind.stem}.edg.xml"])
    for edge in edges.iter("edge"):
        edge.set("numLanes", str(scenario.lanes))
        edge.set("speed", repr(scenario.speed_limit_mps))
        edge.set("width", repr(scenario.lane_width_m))
    _find(nodes, "node", "end", kind.stem).set("x", repr(scenario.length_m))
    if kind.shape is None:
        connections, routes_file = None, VEHICLE_TYPES_FILE
        routes = _traffic_routes(sources[VEHICLE_TYPES_FILE], scenario)
    else:
        connections, routes_file = ElementTree.Element("connections"), f"{kind.stem}.rou.xml"
        flows = kind.shape(scenario, nodes, edges, connections)
        routes = _kind_routes(sources[VEHICLE_TYPES_FILE], sources[routes_file], flows)
    ego_route = _find(ElementTree.fromstring(routes), "route", kind.ego_route_id, routes_file)
    return RoadSources(ElementTree.tostring(nodes), ElementTree.tostring(edges),
                       None if connections is None else ElementTree.tostring(connections), routes,
                       tuple(ego_route.get("edges", "").split()))


def network_routes(scenario: ScenarioConfig, vehicle_types: bytes, ego_route: tuple[str, ...],
                   with_flow: bool, their_types: frozenset[str] | set[str] = frozenset(),
                   through_route: tuple[str, ...] | None = None) -> bytes:
    """The routes file for a network of the user's (kind network): the vehicle types, the ego's route and, with
    `with_flow`, a flow of scenario.flow_veh_per_h along it; where the ego's route leaves the main road
    (`through_route`: the main road's route), scenario.exit_share of that flow along the ego's route and the rest
    along the main road, as on the generated exit road (all of it along the ego's route would queue every vehicle
    into the exit, leaving the ego no gap to take it). Types a user's traffic file defines (`their_types`) are left
    out, as is a distribution of them: the user's win; the ego's type is the project's own."""
    for ego_type in (EGO_TYPE, ACCELERATION_EGO_TYPE):
        if ego_type in their_types:
            raise ConfigError(f"scenario.traffic_file defines a vehicle type {ego_type!r}, the project's name for an "
                              f"ego's type: rename it")
    root = ElementTree.fromstring(vehicle_types)
    _find(root, "vType", EGO_TYPE, VEHICLE_TYPES_FILE)
    flow = _find(root, "flow", "traffic", VEHICLE_TYPES_FILE)
    for element in [*root.findall("route"), flow]:
        root.remove(element)
    drop_types(root, their_types)
    ElementTree.SubElement(root, "route", id="ego_route", edges=" ".join(ego_route))
    if with_flow and through_route is None:
        flow.set("route", "ego_route")
        flow.set("period", _period(scenario.flow_veh_per_h))
        root.append(flow)
    elif with_flow and through_route is not None:
        ElementTree.SubElement(root, "route", id="main_road", edges=" ".join(through_route))
        leaving = copy.deepcopy(flow)
        for element, route, share in ((flow, "main_road", 1.0 - scenario.exit_share),
                                      (leaving, "ego_route", scenario.exit_share)):
            if share == 0.0:
                continue
            element.set("route", route)
            element.set("period", _period(scenario.flow_veh_per_h * share))
            root.append(element)
        leaving.set("id", "route_traffic")
    return ElementTree.tostring(root)


def drop_types(root: ElementTree.Element, type_ids: Collection[str]) -> None:
    """Remove from a routes file's `root` the vehicle types `type_ids` names and the distributions of any of them:
    definitions given elsewhere replace them."""
    for element in [*root.findall("vType"), *root.findall("vTypeDistribution")]:
        members = {element.get("id"), *element.get("vTypes", "").split()}
        if members & set(type_ids):
            root.remove(element)


def _merge(scenario: ScenarioConfig, nodes: ElementTree.Element, edges: ElementTree.Element,
           connections: ElementTree.Element) -> dict[str, float]:
    lanes, width = scenario.lanes, scenario.lane_width_m
    begin, end = scenario.feature_at_m, scenario.feature_at_m + scenario.feature_length_m
    _find(nodes, "node", "merge_begin", "merge").set("x", repr(begin))
    _find(nodes, "node", "merge_end", "merge").set("x", repr(end))
    right_m = -lanes * width  # the main road's right edge
    ramp_start = _find(nodes, "node", "ramp_start", "merge")
    ramp_start.set("y", repr(right_m - RAMP_OFFSET_M))
    _find(edges, "edge", "merge", "merge").set("numLanes", str(lanes + 1))
    # the ramp's line ends at the main road's right edge, so its lane runs straight into the acceleration lane
    ramp = _find(edges, "edge", "ramp", "merge")
    ramp.set("numLanes", "1")
    ramp.set("shape", f"0.0,{right_m - RAMP_OFFSET_M!r} {begin - 300.0!r},{right_m - 10.0!r} {begin!r},{right_m!r}")
    _connect(connections, "main_in", "merge", [(lane, lane + 1) for lane in range(lanes)])
    _connect(connections, "ramp", "merge", [(0, 0)])
    _connect(connections, "merge", "main_out", [(lane + 1, lane) for lane in range(lanes)])
    return {"traffic": scenario.flow_veh_per_h, "ramp_traffic": scenario.ramp_flow_veh_per_h}


def _lane_drop(scenario: ScenarioConfig, nodes: ElementTree.Element, edges: ElementTree.Element,
               connections: ElementTree.Element) -> dict[str, float]:
    lanes, dropped = scenario.lanes, scenario.dropped_lanes
    _find(nodes, "node", "zone_begin", "lane_drop").set("x", repr(scenario.feature_at_m))
    _find(nodes, "node", "zone_end", "lane_drop").set("x", repr(scenario.feature_at_m + scenario.feature_length_m))
    _find(edges, "edge", "zone", "lane_drop").set("numLanes", str(lanes - dropped))
    _connect(connections, "main_in", "zone", [(lane, lane - dropped) for lane in range(dropped, lanes)])
    _connect(connections, "zone", "main_out", [(lane - dropped, lane) for lane in range(dropped, lanes)])
    return {"traffic": scenario.flow_veh_per_h}


def _exit(scenario: ScenarioConfig, nodes: ElementTree.Element, edges: ElementTree.Element,
          connections: ElementTree.Element) -> dict[str, float]:
    lanes, width, diverge = scenario.lanes, scenario.lane_width_m, scenario.feature_at_m
    _find(nodes, "node", "diverge", "exit").set("x", repr(diverge))
    ramp_end = _find(nodes, "node", "ramp_end", "exit")
    right_m = -lanes * width
    ramp_end.set("x", repr(diverge + EXIT_RAMP_M))
    ramp_end.set("y", repr(right_m - RAMP_OFFSET_M))
    off_ramp = _find(edges, "edge", "off_ramp", "exit")
    off_ramp.set("numLanes", "1")
    off_ramp.set("shape", f"{diverge!r},{right_m!r} {diverge + 100.0!r},{right_m - 5.0!r} "
                          f"{diverge + EXIT_RAMP_M!r},{right_m - RAMP_OFFSET_M!r}")
    _connect(connections, "main_in", "main_out", [(lane, lane) for lane in range(lanes)])
    _connect(connections, "main_in", "off_ramp", [(0, 0)])
    return {"traffic": scenario.flow_veh_per_h * (1.0 - scenario.exit_share),
            "exit_traffic": scenario.flow_veh_per_h * scenario.exit_share}


def _connect(connections: ElementTree.Element, source: str, target: str, lane_pairs: list[tuple[int, int]]) -> None:
    for from_lane, to_lane in lane_pairs:
        ElementTree.SubElement(connections, "connection", {"from": source, "to": target, "fromLane": str(from_lane),
                                                           "toLane": str(to_lane)})


def _traffic_routes(data: bytes, scenario: ScenarioConfig) -> bytes:
    """The straight road's routes file: the shipped one with the flow's period set."""
    root = ElementTree.fromstring(data)
    _find(root, "vType", EGO_TYPE, VEHICLE_TYPES_FILE)
    _find(root, "flow", "traffic", VEHICLE_TYPES_FILE).set("period", _period(scenario.flow_veh_per_h))
    return ElementTree.tostring(root)


def _kind_routes(vehicle_types: bytes, kind_routes: bytes, flows_veh_per_h: dict[str, float]) -> bytes:
    """The vehicle types of the straight road's file, then a kind's routes and flows (flows without traffic left
    out: SUMO takes no zero rate)."""
    root = ElementTree.fromstring(vehicle_types)
    _find(root, "vType", EGO_TYPE, VEHICLE_TYPES_FILE)
    for element in [*root.findall("route"), *root.findall("flow")]:
        root.remove(element)
    for element in ElementTree.fromstring(kind_routes):
        if element.tag == "flow":
            rate = flows_veh_per_h.get(element.get("id", ""), 0.0)
            if rate <= 0:
                continue
            element.set("period", _period(rate))
        root.append(element)
    return ElementTree.tostring(root)


def _period(flow_veh_per_h: float) -> str:
    """SUMO's period of Poisson arrivals at `flow_veh_per_h` [veh/h]."""
    return f"exp({flow_veh_per_h / 3600.0!r})"


def _find(root: ElementTree.Element, tag: str, element_id: str, source: str) -> ElementTree.Element:
    element = root.find(f"{tag}[@id='{element_id}']")
    if element is None:
        raise ConfigError(f"network source {source} has no <{tag} id=\"{element_id}\">")
    return element


KIND_SOURCES = {
    "straight": KindSources("highway", "highway_route", "highway", None),
    "merge": KindSources("merge", "main", "merge", _merge),
    "merge_from_ramp": KindSources("merge", "ramp", "merge_from_ramp", _merge),
    "lane_drop": KindSources("lane_drop", "main", "lane_drop", _lane_drop),
    "exit": KindSources("exit", "exit", "exit", _exit),
}


def read_source(path: Path) -> bytes:
    """A shipped or user source file's bytes, checked to be well-formed XML (ConfigError otherwise)."""
    try:
        data = path.read_bytes()
        ElementTree.fromstring(data)
    except OSError as error:
        raise ConfigError(f"cannot read network source {path}: {error.strerror or error}") from error
    except ElementTree.ParseError as error:
        raise ConfigError(f"network source {path} is not well-formed XML: {error}") from error
    return data
