"""Build the highway's .net.xml and traffic file from the plain-XML sources in networks/.

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sumo_rail.config import ConfigError, ScenarioConfig
from sumo_rail.datasets import sumo_version

log = logging.getLogger(__name__)

SOURCE_FILES = ("highway.nod.xml", "highway.edg.xml", "traffic.rou.xml")
EDGE_ID = "highway"
ROUTE_ID = "highway_route"
EGO_TYPE = "ego"


@dataclass(frozen=True)
class BuiltNetwork:
    """Paths of a built scenario."""

    net_file: Path
    routes_file: Path
    directory: Path


def sources_dir() -> Path:
    """The folder holding the shipped plain-XML sources."""
    return Path(str(importlib.resources.files("sumo_rail_networks")))


def cache_dir() -> Path:
    """Root of sumo-rail's cache: $SUMO_RAIL_CACHE, else $XDG_CACHE_HOME/sumo-rail, else ~/.cache/sumo-rail."""
    if os.environ.get("SUMO_RAIL_CACHE"):
        return Path(os.environ["SUMO_RAIL_CACHE"])
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "sumo-rail"


def sumo_binary(name: str) -> str:
    """Path of a SUMO executable (sumo, sumo-gui, netconvert) from the eclipse-sumo package."""
    import sumo

    return os.path.join(sumo.SUMO_HOME, "bin", name)


def build(scenario: ScenarioConfig, source_dir: Path | None = None) -> BuiltNetwork:
    """Build (or reuse from the cache) the network and traffic files for `scenario`."""
    source_dir = source_dir or sources_dir()
    sources = {name: _read_source(source_dir / name) for name in SOURCE_FILES}
    key = _cache_key(scenario, sources)
    directory = cache_dir() / "networks" / key
    built = BuiltNetwork(directory / "highway.net.xml", directory / "traffic.rou.xml", directory)
    routes = _routes_xml(sources["traffic.rou.xml"], scenario)
    problem = _cache_problem(built, scenario, routes)
    if problem is None:
        return built
    if built.net_file.exists() or built.routes_file.exists():
        log.warning("the cached network in %s is damaged (%s); building it again", directory, problem)
    directory.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=directory) as scratch:
        scratch_dir = Path(scratch)
        nodes = _write(scratch_dir / "highway.nod.xml", _nodes_xml(sources["highway.nod.xml"], scenario))
        edges = _write(scratch_dir / "highway.edg.xml", _edges_xml(sources["highway.edg.xml"], scenario))
        net_tmp = scratch_dir / "highway.net.xml"
        _netconvert(nodes, edges, net_tmp)
        routes_tmp = _write(scratch_dir / "traffic.rou.xml", routes)
        os.replace(routes_tmp, built.routes_file)
        os.replace(net_tmp, built.net_file)
    log.info("built network %s", directory)
    return built


def _cache_problem(built: BuiltNetwork, scenario: ScenarioConfig, routes: bytes) -> str | None:
    """What is wrong with a cached network (None: usable): missing files, a traffic file other than the one the
    sources give, a network file that is not well-formed or lacks the highway's lanes."""
    try:
        if built.routes_file.read_bytes() != routes:
            return f"{built.routes_file.name} differs from its sources"
        root = ElementTree.parse(built.net_file).getroot()
    except OSError as error:
        return error.strerror or str(error)
    except ElementTree.ParseError as error:
        return f"{built.net_file.name} is not well-formed XML: {error}"
    edge = root.find(f"edge[@id='{EDGE_ID}']") if root.tag == "net" else None
    if edge is None or len(edge.findall("lane")) != scenario.lanes:
        return f"{built.net_file.name} does not hold the {scenario.lanes}-lane highway"
    return None


def _read_source(path: Path) -> bytes:
    try:
        data = path.read_bytes()
        ElementTree.fromstring(data)
    except OSError as error:
        raise ConfigError(f"cannot read network source {path}: {error.strerror or error}") from error
    except ElementTree.ParseError as error:
        raise ConfigError(f"network source {path} is not well-formed XML: {error}") from error
    return data


def _cache_key(scenario: ScenarioConfig, sources: dict[str, bytes]) -> str:
    digest = hashlib.sha256()
    shaping = {
        "length_m": scenario.length_m,
        "lanes": scenario.lanes,
        "lane_width_m": scenario.lane_width_m,
        "speed_limit_mps": scenario.speed_limit_mps,
        "flow_veh_per_h": scenario.flow_veh_per_h,
        "sumo": sumo_version(),
    }
    digest.update(json.dumps(shaping, sort_keys=True).encode())
    for name in SOURCE_FILES:
        digest.update(name.encode() + b"\0" + sources[name] + b"\0")
    return digest.hexdigest()[:16]


def _find(root: ElementTree.Element, tag: str, element_id: str, source: str) -> ElementTree.Element:
    element = root.find(f"{tag}[@id='{element_id}']")
    if element is None:
        raise ConfigError(f"network source {source} has no <{tag} id=\"{element_id}\">")
    return element


def _nodes_xml(data: bytes, scenario: ScenarioConfig) -> bytes:
    root = ElementTree.fromstring(data)
    _find(root, "node", "end", "highway.nod.xml").set("x", repr(scenario.length_m))
    return ElementTree.tostring(root)


def _edges_xml(data: bytes, scenario: ScenarioConfig) -> bytes:
    root = ElementTree.fromstring(data)
    edge = _find(root, "edge", EDGE_ID, "highway.edg.xml")
    edge.set("numLanes", str(scenario.lanes))
    edge.set("speed", repr(scenario.speed_limit_mps))
    edge.set("width", repr(scenario.lane_width_m))
    return ElementTree.tostring(root)


def _routes_xml(data: bytes, scenario: ScenarioConfig) -> bytes:
    root = ElementTree.fromstring(data)
    _find(root, "vType", EGO_TYPE, "traffic.rou.xml")
    _find(root, "route", ROUTE_ID, "traffic.rou.xml")
    flow = _find(root, "flow", "traffic", "traffic.rou.xml")
    flow.set("period", f"exp({scenario.flow_veh_per_h / 3600.0!r})")
    return ElementTree.tostring(root)


def _write(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def _netconvert(nodes: Path, edges: Path, output: Path) -> None:
    command = [
        sumo_binary("netconvert"),
        "--node-files", str(nodes),
        "--edge-files", str(edges),
        "--output-file", str(output),
        "--no-turnarounds", "true",
        "--offset.disable-normalization", "true",
        "--no-warnings", "true",
    ]
    result = subprocess.run(command, capture_output=True, text=True, check=False)
    if result.returncode != 0:
        message = (result.stderr or result.stdout).strip().splitlines()
        raise ConfigError(f"netconvert failed to build the highway: {message[-1] if message else 'no output'}")


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
