"""A SUMO network of the user's own as the road (`scenario.kind = "network"`): checked, then used as it is.

The network file (for example built by netconvert from an OpenStreetMap extract, docs/scenarios.md) and the ego's
route (`scenario.route`) are checked with sumolib before SUMO starts: the file must be a SUMO network, every edge of
the route must be in it and each must lead to the next. The routes file written to the cache holds the built-in
vehicle types, the ego's route and, without `scenario.traffic_file`, a flow along that route.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import subprocess
import xml.etree.ElementTree as ElementTree
from pathlib import Path

from sumo_rail.config import BOTTLENECK_LANE_CAPACITY_VEH_PER_H, LANE_CAPACITY_VEH_PER_H, ConfigError, ScenarioConfig
from sumo_rail.datasets import sumo_version, write_bytes_atomically
from sumo_rail.sim import scenarios
from sumo_rail.sim.built_network import BuiltNetwork, sumo_binary


def build(scenario: ScenarioConfig, cache_root: Path, vehicle_types_file: Path) -> BuiltNetwork:
    """Check the user's network and route, and write the routes file for them into the cache."""
    net_file = Path(scenario.network).expanduser().resolve()
    ego_route = tuple(scenario.route.split())
    net_bytes = _network_bytes(net_file)
    lane_counts = check_route(net_file, ego_route, scenario.lanes)
    narrowest, capacity = min(lane_counts), lane_capacity(lane_counts)
    traffic_file = None
    if scenario.traffic_file:
        traffic_file = Path(scenario.traffic_file).expanduser().resolve()
        scenarios.read_source(traffic_file)
    elif scenario.flow_veh_per_h > capacity * narrowest:
        raise ConfigError(f"scenario.flow_veh_per_h ({scenario.flow_veh_per_h:g} veh/h) is more than the route's "
                          f"narrowest edge in {net_file.name} ({narrowest} lane{'s' if narrowest > 1 else ''}) can "
                          f"carry (about {capacity:g} veh/h a lane)")
    routes = scenarios.network_routes(scenario, scenarios.read_source(vehicle_types_file), ego_route,
                                      with_flow=traffic_file is None)
    digest = hashlib.sha256(json.dumps({"route": ego_route, "sumo": sumo_version(),
                                        "traffic": str(traffic_file)}).encode())
    digest.update(net_bytes + b"\0" + routes)
    directory = cache_root / "networks" / digest.hexdigest()[:16]
    routes_file = directory / "traffic.rou.xml"
    loads = directory / "sumo_loads"  # written once SUMO has loaded these files
    if not loads.exists():
        check_sumo_loads(net_file, traffic_file)
    if not (routes_file.exists() and routes_file.read_bytes() == routes):
        directory.mkdir(parents=True, exist_ok=True)
        write_bytes_atomically(routes_file, routes)
    if not loads.exists():
        write_bytes_atomically(loads, b"")
    return BuiltNetwork(net_file, routes_file, directory, ego_route, traffic_file)


def _network_bytes(net_file: Path) -> bytes:
    try:
        data = net_file.read_bytes()
        root = ElementTree.fromstring(data)
    except OSError as error:
        raise ConfigError(f"cannot read scenario.network {net_file}: {error.strerror or error}") from error
    except ElementTree.ParseError as error:
        raise ConfigError(f"scenario.network {net_file} is not well-formed XML: {error}") from error
    if root.tag != "net":
        raise ConfigError(f"scenario.network {net_file} is not a SUMO network (its root element is <{root.tag}>, "
                          f"not <net>)")
    return data


def check_sumo_loads(net_file: Path, traffic_file: Path | None) -> None:
    """ConfigError with SUMO's first error unless SUMO itself loads the network (and the traffic file): sumolib reads
    files SUMO refuses, such as a lane without its shape."""
    command = [sumo_binary("sumo"), "--net-file", str(net_file), "--end", "0", "--no-step-log", "true",
               "--no-warnings", "true", *(["--route-files", str(traffic_file)] if traffic_file else [])]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        errors = [line.removeprefix("Error: ").strip() for line in (result.stderr + result.stdout).splitlines()
                  if line.startswith("Error: ")]
        loaded = f"{net_file.name}{f' with {traffic_file.name}' if traffic_file else ''}"
        raise ConfigError(f"SUMO cannot load scenario.network {loaded}: {errors[0] if errors else 'no output'}")


def lane_capacity(lane_counts: list[int]) -> float:
    """The most traffic a lane of the route's narrowest edge may carry [veh/h], from the lane counts of its edges in
    order: the road's start's (the excess waits off the road) unless a later edge has fewer lanes (there it jams)."""
    return LANE_CAPACITY_VEH_PER_H if min(lane_counts) == lane_counts[0] else BOTTLENECK_LANE_CAPACITY_VEH_PER_H


def check_route(net_file: Path, ego_route: tuple[str, ...], lanes: int) -> list[int]:
    """The lane counts of the route's edges, in order; ConfigError unless every edge of `ego_route` is in the network,
    each leads to the next, and the route's widest edge has `lanes` lanes (the observation's lane count)."""
    import sumolib

    try:
        net = sumolib.net.readNet(str(net_file))
    except (KeyError, ValueError, IndexError, AttributeError, TypeError) as error:
        raise ConfigError(f"scenario.network {net_file.name} is a damaged SUMO network: sumolib cannot read it "
                          f"({type(error).__name__}: {error})") from error
    for edge in ego_route:
        if not net.hasEdge(edge):
            raise ConfigError(f"scenario.route's edge {edge!r} is not in {net_file.name}")
    for source, target in itertools.pairwise(ego_route):
        if net.getEdge(target) not in net.getEdge(source).getOutgoing():
            raise ConfigError(f"scenario.route is not connected: edge {source!r} does not lead to {target!r} in "
                              f"{net_file.name}")
    counts = [net.getEdge(edge).getLaneNumber() for edge in ego_route]
    if max(counts) != lanes:
        raise ConfigError(f"scenario.lanes is {lanes} but the route's widest edge in {net_file.name} has {max(counts)} "
                          f"lanes; set --set scenario.lanes={max(counts)}")
    return counts
