"""Build a road's .net.xml and traffic file from the plain-XML sources in networks/ (`scenarios`), or take a user's
network (`user_network`).

Outputs are cached under `cache_dir()/networks/<hash>/`, keyed by the sources' bytes, the scenario settings
that shape them and the SUMO version, so they are rebuilt exactly when one of those changes. Files are
written to a temporary name and renamed, so concurrent builders never see a half-written file. A cached entry is
checked before use (the traffic file byte for byte, the network's structure) and built again when damaged.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import importlib.resources
import json
import logging
import math
import os
import subprocess
import tempfile
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np

from sumo_rail.config import Config, ConfigError, ScenarioConfig
from sumo_rail.datasets import sumo_version, written_atomically
from sumo_rail.sim import scenarios, user_network
from sumo_rail.sim.built_network import BuiltNetwork, sumo_binary

log = logging.getLogger(__name__)

EDGE_ID = "highway"
"""The straight road's one edge."""
EGO_TYPE = scenarios.EGO_TYPE
ACCELERATION_EGO_TYPE = scenarios.ACCELERATION_EGO_TYPE


def sources_dir() -> Path:
    """The folder holding the shipped plain-XML sources."""
    return Path(str(importlib.resources.files("sumo_rail_networks")))


def cache_dir() -> Path:
    """Root of sumo-rail's cache: $SUMO_RAIL_CACHE, else $XDG_CACHE_HOME/sumo-rail, else ~/.cache/sumo-rail."""
    if os.environ.get("SUMO_RAIL_CACHE"):
        return Path(os.environ["SUMO_RAIL_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "sumo-rail"


def check_user_route(config: Config) -> None:
    """`user_network.check_start_window` on a user's network (kind network), as the CLI checks it before any work:
    for an env built from Python, before its first simulation starts."""
    if config.scenario.kind == "network":
        user_network.check_start_window(config.env, build(config.scenario))


def road_length_m(config: Config) -> float:
    """The length of the ego's road [m]: a user's route's own (kind network), else scenario.length_m."""
    if config.scenario.kind == "network":
        length_m = build(config.scenario).route_length_m
        assert length_m is not None
        return length_m
    return config.scenario.length_m


def latest_start_m(config: Config) -> float:
    """The farthest along a user's route an ego may start [m]: `user_network.exit_clearance_m` before where the route
    leaves the main road; inf where it keeps to it and on the generated roads (their config checks the window)."""
    if config.scenario.kind != "network":
        return math.inf
    built = build(config.scenario)
    return math.inf if built.exit_at_m is None else built.exit_at_m - user_network.exit_clearance_m(built.start_lanes)


def build(scenario: ScenarioConfig, source_dir: Path | None = None) -> BuiltNetwork:
    """Build (or reuse from the cache) the network and traffic files for `scenario`."""
    if scenario.kind == "network":
        return user_network.build(scenario, cache_dir(), (source_dir or sources_dir()) / scenarios.VEHICLE_TYPES_FILE)
    source_dir = source_dir or sources_dir()
    names = scenarios.source_names(scenario.kind)
    road = scenarios.road_sources(scenario, {name: scenarios.read_source(source_dir / name) for name in names})
    key = _cache_key(scenario, road)
    directory = cache_dir() / "networks" / key
    stem, route_id = scenarios.KIND_SOURCES[scenario.kind].net_stem, scenarios.KIND_SOURCES[scenario.kind].ego_route_id
    built = BuiltNetwork(directory / f"{stem}.net.xml", directory / "traffic.rou.xml", directory, road.ego_route,
                         route_id=route_id)
    problem = _cache_problem(built, road.routes)
    if problem is None:
        return built
    if built.net_file.exists() or built.routes_file.exists():
        log.warning("the cached network in %s is damaged (%s); building it again", directory, problem)
    directory.mkdir(parents=True, exist_ok=True)
    # the routes are renamed into place first, the network last (the inner block ends first)
    with (tempfile.TemporaryDirectory(dir=directory) as scratch, written_atomically(built.net_file) as net_tmp,
          written_atomically(built.routes_file) as routes_tmp):
        scratch_dir = Path(scratch)
        inputs = {kind: _write(scratch_dir / f"{stem}.{kind[:3]}.xml", data) for kind, data in road.files.items()
                  if kind != "routes"}
        netconvert(inputs, net_tmp)
        _write(routes_tmp, road.routes)
    log.info("built network %s", directory)
    return built


def _cache_problem(built: BuiltNetwork, routes: bytes) -> str | None:
    """What is wrong with a cached network (None: usable): missing files, a traffic file other than the one the
    sources give, a network file that is not well-formed or lacks an edge of the ego's route."""
    try:
        if built.routes_file.read_bytes() != routes:
            return f"{built.routes_file.name} differs from its sources"
        root = ElementTree.parse(built.net_file).getroot()
    except OSError as error:
        return error.strerror or str(error)
    except ElementTree.ParseError as error:
        return f"{built.net_file.name} is not well-formed XML: {error}"
    edges = {edge.get("id") for edge in root.iter("edge")} if root.tag == "net" else set()
    missing = [edge for edge in built.ego_route if edge not in edges]
    if missing:
        return f"{built.net_file.name} lacks edge {missing[0]} of the ego's route"
    return None


def _cache_key(scenario: ScenarioConfig, road: scenarios.RoadSources) -> str:
    """The key of a road's cache folder: its sources with the scenario's settings applied, those settings and the
    SUMO version."""
    digest = hashlib.sha256()
    shaping: dict[str, object] = {
        "length_m": scenario.length_m,
        "lanes": scenario.lanes,
        "lane_width_m": scenario.lane_width_m,
        "speed_limit_mps": scenario.speed_limit_mps,
        "flow_veh_per_h": scenario.flow_veh_per_h,
        "sumo": sumo_version(),
    }
    if scenario.kind != "straight":
        shaping["kind"] = scenario.kind
    digest.update(json.dumps(shaping, sort_keys=True).encode())
    for name, data in road.files.items():
        digest.update(name.encode() + b"\0" + data + b"\0")
    return digest.hexdigest()[:16]


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def netconvert(inputs: dict[str, Path], output: Path) -> None:
    """Build the network `output` from plain-XML `inputs` ("nodes", "edges", optionally "connections": their paths) with
    SUMO's netconvert, as this project builds every road; ConfigError with netconvert's last line when it fails."""
    command = [
        sumo_binary("netconvert"),
        "--node-files", str(inputs["nodes"]),
        "--edge-files", str(inputs["edges"]),
        *(["--connection-files", str(inputs["connections"])] if "connections" in inputs else []),
        "--output-file", str(output),
        "--no-turnarounds", "true",
        "--offset.disable-normalization", "true",
        "--no-warnings", "true",
    ]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        message = (result.stderr or result.stdout).strip().splitlines()
        raise ConfigError(f"netconvert failed to build the road: {message[-1] if message else 'no output'}")


def warm_state_key(scenario: ScenarioConfig, built: BuiltNetwork, options: list[str], traffic_seed: int) -> str:
    """The cache key of one warm-up run's states: the network, SUMO's `options` (without its input files), the
    warm-up's times [s] and number of states, and its traffic seed."""
    settings = {
        "network": built.directory.name,
        "options": options,
        "warmup_s": scenario.warmup_s,
        "snapshots": scenario.snapshots,
        "snapshot_interval_s": scenario.snapshot_interval_s,
        "traffic_seed": traffic_seed,
    }
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]


def warm_state_problem(path: Path, k: int, scenario: ScenarioConfig) -> str | None:
    """What is wrong with cached warm state `k` of `scenario` (None: usable): missing, not well-formed XML, not a
    SUMO state or not of the time [s] warm state `k` is saved at."""
    try:
        root = ElementTree.parse(path).getroot()
    except OSError as error:
        return f"{path.name}: {error.strerror or error}"
    except ElementTree.ParseError as error:
        return f"{path.name} is not well-formed XML: {error}"
    expected_s = scenario.warmup_s + k * scenario.snapshot_interval_s
    try:
        time_s = float(root.get("time", "nan"))
    except ValueError:
        time_s = math.nan
    slack_s = (k + 1) * scenario.step_length_s + 1e-6  # each simulationStep(t) may overshoot t by a step
    if root.tag != "snapshot" or not expected_s - 1e-6 <= time_s <= expected_s + slack_s:
        return f"{path.name} is not SUMO's state at {expected_s:g} s"
    return None


def offset_polyline(points: np.ndarray, offset_m: float) -> np.ndarray:
    """Shift each vertex of a polyline sideways by `offset_m` (positive = left of travel) [m]."""
    direction = np.gradient(points, axis=0)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    normal_left = np.stack([-direction[:, 1], direction[:, 0]], axis=1)
    return points + offset_m * normal_left


def segments(points: np.ndarray) -> np.ndarray:
    """Consecutive vertex pairs of a polyline as segments, shape (N - 1, 2, 2)."""
    return np.stack([points[:-1], points[1:]], axis=1)
