"""The road of a scene: a straight SUMO edge built with netconvert from a recording's lanes (highD, NGSIM), and the
lanes of any SUMO network (the user's, for FCD) read back for checks and writers.

The built road is one edge `ROAD_EDGE` along +x from x = 0 to its length, its lanes spread to the right of y = 0
(the road's left edge), lane 0 the rightmost, as the package's own straight highway (`sumo_rail.sim.network`).
"""

from __future__ import annotations

import itertools
import tempfile
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sumo_rail.config import ConfigError
from sumo_rail.datasets import DatasetError
from sumo_rail.sim.network import netconvert
from sumo_rail.sim.user_traffic import read_xml

ROAD_EDGE = "road"
"""The built road's edge (its driving direction's, toward +x)."""
OPPOSITE_EDGE = "road_opposite"
"""The other carriageway's edge of a road built for both driving directions (toward -x)."""
ON_RAMP_EDGE = "road_on_ramp"
"""The stretch of a road built with a ramp lane where an on-ramp runs beside it (`build_road`)."""
OFF_RAMP_EDGE = "road_off_ramp"
"""The stretch of a road built with a ramp lane where an off-ramp runs beside it (`build_road`)."""
ROAD_SPEED_MPS = 44.44
"""The built road's speed limit [m/s] (160 km/h): the recordings' own limits vary; SUMO only needs a bound."""


@dataclass(frozen=True)
class NetworkLanes:
    """What a scene needs of a SUMO network: each edge's lane widths [m] and centre lines ((P, 2) x, y points [m]),
    rightmost first, and its length (its longest lane's) [m]."""

    widths_m: dict[str, tuple[float, ...]]
    lengths_m: dict[str, float]
    shapes_m: dict[str, tuple[np.ndarray, ...]]

    def lanes(self, edge: str) -> int:
        """Number of lanes of `edge`."""
        return len(self.widths_m[edge])


def build_road(lane_widths_m: list[float], length_m: float, out: Path,
               opposite_lane_widths_m: list[float] | None = None, median_m: float = 0.0,
               ramp_lane_m: tuple[float, float] | None = None) -> None:
    """Write a straight road of `length_m` [m] with lanes of `lane_widths_m` [m] (rightmost first) to `out` with
    netconvert (plain XML nodes and one edge, `ROAD_EDGE`); with `opposite_lane_widths_m`, the other carriageway too
    (`OPPOSITE_EDGE`, driven toward -x, its left edge `median_m` [m] above y = 0); with `ramp_lane_m` (a, b) [m], one
    more lane on the right (as wide as the rightmost) from x = 0 to a (`ON_RAMP_EDGE`, an on-ramp merging into the
    rightmost lane; none when a is 0) and from b to the end (`OFF_RAMP_EDGE`, an off-ramp leaving it; none when b is
    the length), every other lane keeping its place from the left. The same lanes give the same bytes."""
    nodes = ElementTree.Element("nodes")
    edges = ElementTree.Element("edges")
    connections = ElementTree.Element("connections")
    carriageways = [(ROAD_EDGE, lane_widths_m, (0.0, float(length_m)), 0.0)]
    if ramp_lane_m is not None:
        carriageways = _ramp_segments(lane_widths_m, float(length_m), ramp_lane_m, connections)
    if opposite_lane_widths_m:
        carriageways.append((OPPOSITE_EDGE, opposite_lane_widths_m, (float(length_m), 0.0), median_m))
    for edge_id, widths, (start_x, end_x), y in carriageways:
        start, end = ("start", "end") if edge_id == ROAD_EDGE else (f"{edge_id}_start", f"{edge_id}_end")
        if ramp_lane_m is not None and edge_id != OPPOSITE_EDGE:  # segments of one carriageway meet at nodes
            start, end = f"at_{start_x:g}", f"at_{end_x:g}"
        for node, x in ((start, start_x), (end, end_x)):
            if nodes.find(f"node[@id='{node}']") is None:
                ElementTree.SubElement(nodes, "node", id=node, x=repr(x), y=repr(y), type="priority")
        edge = ElementTree.SubElement(edges, "edge", id=edge_id, attrib={
            "from": start, "to": end, "priority": "10", "numLanes": str(len(widths)), "speed": repr(ROAD_SPEED_MPS)})
        for index, width in enumerate(widths):
            ElementTree.SubElement(edge, "lane", index=str(index), width=f"{width:.3f}")
    with tempfile.TemporaryDirectory() as scratch:
        inputs = {"nodes": Path(scratch) / "road.nod.xml", "edges": Path(scratch) / "road.edg.xml"}
        if len(connections):
            inputs["connections"] = Path(scratch) / "road.con.xml"
            ElementTree.ElementTree(connections).write(inputs["connections"])
        ElementTree.ElementTree(nodes).write(inputs["nodes"])
        ElementTree.ElementTree(edges).write(inputs["edges"])
        built = Path(scratch) / "road.net.xml"
        try:
            netconvert(inputs, built)
        except ConfigError as error:
            raise DatasetError(str(error)) from error
        text = built.read_text()
    # netconvert's header comment holds the time and the scratch paths: dropped, so that the same recording gives
    # the same bytes
    head, _, rest = text.partition("<!--")
    out.write_text(head + rest.partition("-->")[2].lstrip("\n") if rest else text)


def _ramp_segments(lane_widths_m: list[float], length_m: float, ramp_lane_m: tuple[float, float],
                   connections: ElementTree.Element) -> list[tuple[str, list[float], tuple[float, float], float]]:
    """The carriageway of `build_road` with a ramp lane (its segments: edge, lane widths, x span, y) and the
    connections where the ramp lane ends or begins (added to `connections`)."""
    on_m, off_m = ramp_lane_m
    wider = [lane_widths_m[0], *lane_widths_m]
    segments = [(ON_RAMP_EDGE, wider, (0.0, on_m), 0.0)] if on_m > 0 else []
    segments.append((ROAD_EDGE, lane_widths_m, (on_m, off_m), 0.0))
    if off_m < length_m:
        segments.append((OFF_RAMP_EDGE, wider, (off_m, length_m), 0.0))
    for (source, source_widths, _, _), (target, target_widths, _, _) in itertools.pairwise(segments):
        # lanes keep their place from the left; the ramp lane merges into the rightmost lane, or leaves it
        merging = len(source_widths) > len(target_widths)
        links = ([(lane, max(lane - 1, 0)) for lane in range(len(source_widths))] if merging else
                 [(0, 0)] + [(lane, lane + 1) for lane in range(len(source_widths))])
        for lane, to in links:
            ElementTree.SubElement(connections, "connection", attrib={
                "from": source, "to": target, "fromLane": str(lane), "toLane": str(to)})
    return segments


def place_on_road(net_file: Path, x_m: np.ndarray, from_left: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The edge, lane index and lane position [m] of fronts at `x_m` [m] in lanes `from_left` (1 = the leftmost) on
    the +x carriageway of a road `build_road` built (its junctions' lanes included); a lane index below 0 where the
    road has no such lane there."""
    lanes = read_lanes(net_file)
    ids = sorted((edge for edge in lanes.widths_m if edge != OPPOSITE_EDGE),
                 key=lambda edge: float(lanes.shapes_m[edge][0][0][0]))
    starts = np.array([float(lanes.shapes_m[edge][0][0][0]) for edge in ids])
    at = np.clip(np.searchsorted(starts, x_m, side="right") - 1, 0, len(ids) - 1)
    lane = np.array([lanes.lanes(edge) for edge in ids])[at] - from_left
    return np.array(ids, dtype=object)[at], lane, x_m - starts[at]


def network_root(net_file: Path) -> ElementTree.Element:
    """The root element of a SUMO network file, plain or gzip-compressed (`.gz`), read as `scenario.network` is;
    DatasetError naming the file when it cannot be read or is not XML."""
    try:
        return read_xml(net_file, "network")
    except ConfigError as error:
        raise DatasetError(str(error)) from error


def read_lanes(net_file: Path) -> NetworkLanes:
    """Each edge's lane widths, centre lines and length in a SUMO .net.xml (or .net.xml.gz), internal (junction)
    edges included; DatasetError naming the file when it is not a SUMO network."""
    lanes: dict[str, list[tuple[int, float, float, np.ndarray]]] = {}
    root = network_root(net_file)
    try:
        for edge in root.iter("edge"):
            for lane in edge.iter("lane"):
                shape = np.array([[float(value) for value in point.split(",")[:2]]
                                  for point in lane.get("shape", "").split()]).reshape(-1, 2)
                lanes.setdefault(edge.get("id", ""), []).append((int(lane.get("index", "0")),
                                                                 float(lane.get("width", "3.2")),
                                                                 float(lane.get("length", "0")), shape))
    except ValueError as error:
        raise DatasetError(f"network {net_file} is not a readable SUMO network ({error})") from error
    if not lanes:
        raise DatasetError(f"network {net_file} has no edges with lanes; it is not a SUMO network")
    ordered = {edge: sorted(found, key=lambda lane: lane[0]) for edge, found in lanes.items()}
    return NetworkLanes({edge: tuple(lane[1] for lane in found) for edge, found in ordered.items()},
                        {edge: max(lane[2] for lane in found) for edge, found in ordered.items()},
                        {edge: tuple(lane[3] for lane in found) for edge, found in ordered.items()})


def straight_road(net_file: Path) -> tuple[float, ...]:
    """The lane widths [m], rightmost first, of a network that is one straight edge along +x whose left edge is
    y = 0 (a road `build_road` built, or the package's straight highway); DatasetError otherwise, as highD and NGSIM
    files can only describe such a road."""
    lanes = read_lanes(net_file)
    edges = [edge for edge in lanes.widths_m if not edge.startswith(":")]
    if len(edges) != 1:
        raise DatasetError(f"network {net_file} has {len(edges)} edges; highD and NGSIM files describe one straight "
                           f"road")
    return lanes.widths_m[edges[0]]
