"""A SUMO network of the user's own as the road (`scenario.kind = "network"`): checked, then used as it is.

The network file (for example built by netconvert from an OpenStreetMap extract, docs/scenarios.md) and the ego's
route (`scenario.route`) are checked with sumolib before SUMO starts: the file (plain or `.gz`) must be a SUMO
network, every edge of the route must be in it, each must lead to the next, have a lane a passenger car may use and
end at no traffic light. The routes file written to the cache holds the built-in vehicle types (less those a user's
traffic file defines: the user's win), the ego's route and, without `scenario.traffic_file`, a flow along that route.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import os
import subprocess
from pathlib import Path
from typing import Any

from sumo_rail.bounds import bounds_of
from sumo_rail.config import (
    BOTTLENECK_LANE_CAPACITY_VEH_PER_H,
    LANE_CAPACITY_VEH_PER_H,
    ConfigError,
    EnvConfig,
    ScenarioConfig,
)
from sumo_rail.datasets import file_sha256, sumo_version, write_bytes_atomically
from sumo_rail.sim import scenarios, user_traffic
from sumo_rail.sim.built_network import BuiltNetwork, sumo_binary

EGO_CLASS = "passenger"
"""The ego's SUMO vehicle class (its vType in networks/traffic.rou.xml)."""


def build(scenario: ScenarioConfig, cache_root: Path, vehicle_types_file: Path) -> BuiltNetwork:
    """Check the user's network and route, and write the routes file for them into the cache."""
    net_file = Path(scenario.network).expanduser().resolve()
    ego_route = tuple(scenario.route.split())
    net_bytes = _network_bytes(net_file)
    lane_counts, route_length_m, speed_limit_mps, through, exit_at_m = check_route(net_file, ego_route,
                                                                                   scenario.lanes)
    narrowest, capacity = min(lane_counts), lane_capacity(lane_counts)
    traffic_file, their_types = None, set[str]()
    if scenario.traffic_file:
        traffic_file = Path(scenario.traffic_file).expanduser().resolve()
        their_types = user_traffic.user_types(traffic_file, scenario)
    elif scenario.flow_veh_per_h > capacity * narrowest:
        raise ConfigError(f"scenario.flow_veh_per_h ({scenario.flow_veh_per_h:g} veh/h) is more than the route's "
                          f"narrowest edge in {net_file.name} ({narrowest} lane{'s' if narrowest > 1 else ''}) can "
                          f"carry (about {capacity:g} veh/h a lane)")
    routes = scenarios.network_routes(scenario, scenarios.read_source(vehicle_types_file), ego_route,
                                      with_flow=traffic_file is None, their_types=their_types, through_route=through)
    digest = hashlib.sha256(json.dumps({"route": ego_route, "sumo": sumo_version(),
                                        "traffic": str(traffic_file)}).encode())
    digest.update(net_bytes + b"\0" + routes)
    directory = cache_root / "networks" / digest.hexdigest()[:16]
    routes_file = directory / "traffic.rou.xml"
    loads = directory / "sumo_loads"  # written once SUMO has loaded these files
    if not (routes_file.exists() and routes_file.read_bytes() == routes):
        directory.mkdir(parents=True, exist_ok=True)
        write_bytes_atomically(routes_file, routes)
    if not loads.exists():
        check_sumo_loads(net_file, [routes_file, *([traffic_file] if traffic_file else [])])
        write_bytes_atomically(loads, b"")
    return BuiltNetwork(net_file, routes_file, directory, ego_route, traffic_file, route_length_m=route_length_m,
                        speed_limit_mps=speed_limit_mps, exit_at_m=exit_at_m, start_lanes=lane_counts[0])


def absolute_paths(scenario: ScenarioConfig) -> dict[str, str]:
    """scenario.network and scenario.traffic_file (when given) as absolute paths, as settings to replace."""
    return {key: str(Path(getattr(scenario, key)).expanduser().resolve())
            for key in ("network", "traffic_file") if getattr(scenario, key)}


def road_files(scenario: ScenarioConfig) -> dict[str, str]:
    """The content hash (sha256) of a user's network and traffic file by absolute path, as outputs' provenance holds
    them (kind network; empty for the generated roads, whose settings make them)."""
    return {path: file_sha256(Path(path)) for path in absolute_paths(scenario).values()} \
        if scenario.kind == "network" else {}


EXIT_PER_CHANGE_M = 150.0
"""Road [m] the ego's start window leaves before its route's exit for each lane change across the first edge. On a
3-lane motorway whose exit netconvert's --ramps.guess gives a deceleration lane (2 changes from the left lane, a third
once on it), the expert starting 100-300 m before the exit missed it in 2 of 100 episodes (230-300 m: 2 of 200, both
about 235 m), 300-350 m before in none of 500 (1500 and 2000 veh/h); on 4 lanes 150-300 m before in 1 of 100, 450-500
m in none of 200."""


def exit_clearance_m(start_lanes: int) -> float:
    """The least distance [m] from the end of the start window to where the route leaves the main road, for a first
    edge of `start_lanes` lanes: `EXIT_PER_CHANGE_M` for each of its lanes but one (at least one)."""
    return EXIT_PER_CHANGE_M * max(start_lanes - 1, 1)


def check_start_window(env: EnvConfig, built: BuiltNetwork) -> None:
    """ConfigError unless the ego's start window and end margin fit on a user's route (its own length counts), the
    window ends `exit_clearance_m` before the route leaves the main road and its speed limit is above env.v_min_mps
    (the set-points lie between them)."""
    if built.speed_limit_mps is not None and built.speed_limit_mps <= env.v_min_mps:
        raise ConfigError(f"scenario.route's speed limit in {built.net_file.name} ({built.speed_limit_mps:g} m/s) "
                          f"must be above env.v_min_mps ({env.v_min_mps:g} m/s); lower env.v_min_mps")
    if built.route_length_m is not None and env.ego_start_max_m + env.end_margin_m >= built.route_length_m:
        raise ConfigError(f"env.ego_start_max_m + env.end_margin_m ({env.ego_start_max_m + env.end_margin_m:g} m) "
                          f"must be shorter than scenario.route ({built.route_length_m:.0f} m long in "
                          f"{built.net_file.name}); lower them or choose a longer route")
    clearance_m = exit_clearance_m(built.start_lanes)
    if built.exit_at_m is not None and env.ego_start_max_m + clearance_m > built.exit_at_m:
        raise ConfigError(f"env.ego_start_max_m ({env.ego_start_max_m:g} m) must end at least {clearance_m:g} m before "
                          f"scenario.route leaves the main road at {built.exit_at_m:.0f} m in {built.net_file.name} "
                          f"({EXIT_PER_CHANGE_M:g} m for each lane change across its first edge's "
                          f"{built.start_lanes} lane{'s' if built.start_lanes > 1 else ''}, else the ego may miss the "
                          f"exit); lower env.ego_start_max_m or start the route farther back")


def _network_bytes(net_file: Path) -> bytes:
    root = user_traffic.read_xml(net_file, "scenario.network")
    if root.tag == "configuration":
        inputs = {tag: element.get("value", "") for tag in ("net-file", "route-files")
                  for element in root.iter(tag)}
        raise ConfigError(f"scenario.network {net_file.name} is a SUMO configuration, not a network: give its "
                          f"net-file ({inputs.get('net-file') or 'none'}) as scenario.network and its route-files "
                          f"({inputs.get('route-files') or 'none'}) as scenario.traffic_file")
    if root.tag != "net":
        raise ConfigError(f"scenario.network {net_file} is not a SUMO network (its root element is <{root.tag}>, "
                          f"not <net>)")
    return net_file.read_bytes()


def check_sumo_loads(net_file: Path, route_files: list[Path]) -> None:
    """ConfigError with SUMO's first error unless SUMO itself loads the network with the route files (the built-in
    ones, then a user's traffic): sumolib reads files SUMO refuses, such as a lane without its shape."""
    errors = sumo_load_errors(net_file, route_files)
    if errors:
        loaded = f"{net_file.name}{f' with {route_files[1].name}' if len(route_files) > 1 else ''}"
        raise ConfigError(f"SUMO cannot load scenario.network {loaded}: {errors[0]}")


def sumo_load_errors(net_file: Path, route_files: list[Path], validate: bool = False) -> list[str]:
    """SUMO's errors loading the network `net_file` with `route_files` (none: it loads them); with `validate`, the
    route files checked against SUMO's schema instead (an attribute SUMO does not know is refused, not ignored)."""
    command = [sumo_binary("sumo"), "--net-file", str(net_file), "--end", "0", "--no-step-log", "true",
               "--no-warnings", "true", "--route-files", ",".join(str(path) for path in route_files)]
    environment = None
    if validate:  # SUMO finds its schemas under SUMO_HOME
        environment = {**os.environ, "SUMO_HOME": str(Path(sumo_binary("sumo")).parents[1])}
        command += ["--xml-validation.routes", "always"]
    result = subprocess.run(command, capture_output=True, text=True, check=False, env=environment)
    errors = [line.removeprefix("Error: ").strip() for line in (result.stderr + result.stdout).splitlines()
              if line.startswith("Error: ")]  # some (an unknown vehicle class) leave SUMO's exit status 0
    return errors or (["no output"] if result.returncode else [])


MAIN_ROAD_EDGES = 200
"""The longest main-road route `through_route` follows [edges]."""


def lane_capacity(lane_counts: list[int]) -> float:
    """The most traffic a lane of the route's narrowest edge may carry [veh/h], from the lane counts of its edges in
    order: the road's start's (the excess waits off the road) unless a later edge has fewer lanes (there it jams)."""
    return LANE_CAPACITY_VEH_PER_H if min(lane_counts) == lane_counts[0] else BOTTLENECK_LANE_CAPACITY_VEH_PER_H


def check_route(net_file: Path, ego_route: tuple[str, ...],
                lanes: int) -> tuple[list[int], float, float, tuple[str, ...] | None, float | None]:
    """The lane counts of the route's edges, in order, the route's length [m], its highest speed limit [m/s], the
    main road's route where the ego's leaves it (`through_route`) and where that is along the route (the end of its
    last shared edge) [m]; None, None: it keeps to the main road. ConfigError unless every edge of
    `ego_route` is in the network, each leads to the next, has a lane the ego's class (passenger) may use and ends
    at no traffic light before the route's end, and the route's widest edge has `lanes` lanes (the observation's)."""
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
    for edge in ego_route:
        if not any(lane.allows(EGO_CLASS) for lane in net.getEdge(edge).getLanes()):
            raise ConfigError(f"scenario.route's edge {edge!r} in {net_file.name} has no lane a {EGO_CLASS} car may "
                              f"use (the ego's class); route the ego around it")
    for edge in ego_route[:-1]:
        if net.getEdge(edge).getToNode().getType().startswith("traffic_light"):
            raise ConfigError(f"scenario.route's edge {edge!r} in {net_file.name} ends at a traffic light, which the "
                              f"ego does not obey; choose a route without traffic lights")
    counts = [net.getEdge(edge).getLaneNumber() for edge in ego_route]
    if max(counts) != lanes:
        bounds = bounds_of(next(field for field in dataclasses.fields(ScenarioConfig) if field.name == "lanes"))
        advice = (f"set --set scenario.lanes={max(counts)}" if bounds is None or bounds.holds(max(counts)) else
                  f"scenario.lanes must be {bounds.describe()}: choose a route with fewer lanes")
        raise ConfigError(f"scenario.lanes is {lanes} but the route's widest edge in {net_file.name} has {max(counts)} "
                          f"lanes; {advice}")
    edges = [net.getEdge(edge) for edge in ego_route]
    through = through_route(net, ego_route)
    exit_at_m = None
    if through is not None:
        pairs = enumerate(zip(ego_route, through, strict=False))
        shared = next((index for index, (ours, main) in pairs if ours != main), len(through))
        exit_at_m = sum(edge.getLength() for edge in edges[:shared])
    return (counts, sum(edge.getLength() for edge in edges), max(edge.getSpeed() for edge in edges), through,
            exit_at_m)


def through_route(net: Any, ego_route: tuple[str, ...]) -> tuple[str, ...] | None:
    """Where the ego's route leaves the main road (at a junction it takes another edge than the main one: the
    successor with the most lanes, then the highest priority, then the id), the main road's route: the ego's edges
    up to there, then the main edge after each junction until the road ends (or `MAIN_ROAD_EDGES` edges); None
    when the ego's route keeps to the main road."""
    def main_after(edge: Any) -> Any:
        successors = [after for after in edge.getOutgoing() if after.allows(EGO_CLASS)]
        return max(successors, key=lambda after: (after.getLaneNumber(), after.getPriority(), after.getID()),
                   default=None)

    for index, (edge_id, next_id) in enumerate(itertools.pairwise(ego_route)):
        main = main_after(net.getEdge(edge_id))
        if main is not None and main.getID() != next_id:
            route = [*ego_route[:index + 1]]
            while main is not None and main.getID() not in route and len(route) < MAIN_ROAD_EDGES:
                route.append(main.getID())
                main = main_after(main)
            return tuple(route)
    return None
