"""A user's own traffic file (`scenario.traffic_file`, kind network), checked before SUMO starts: a SUMO route file
whose traffic lasts past the warm-up and its snapshots, and the vehicle types it defines (they win over the
project's built-in ones of the same name)."""

from __future__ import annotations

import gzip
import xml.etree.ElementTree as ElementTree
import zlib
from pathlib import Path

from sumo_rail.config import ConfigError, ScenarioConfig

FLOW_DEFAULT_END_S = 86_400.0
"""SUMO's end of a flow without `end` or `number` [s]."""


def read_xml(path: Path, setting: str) -> ElementTree.Element:
    """The root element of a SUMO input file, plain or gzip-compressed (`.gz`); ConfigError naming `setting` when it
    cannot be read or is not XML."""
    try:
        data = path.read_bytes()
        return ElementTree.fromstring(gzip.decompress(data) if path.suffix == ".gz" else data)
    except OSError as error:
        raise ConfigError(f"cannot read {setting} {path}: {error.strerror or error}") from error
    except (EOFError, zlib.error) as error:  # a gzip file cut short or damaged
        raise ConfigError(f"cannot read {setting} {path}: it is a damaged gzip file ({error})") from error
    except ElementTree.ParseError as error:
        raise ConfigError(f"{setting} {path} is not well-formed XML: {error}") from error


def user_types(traffic_file: Path, scenario: ScenarioConfig) -> set[str]:
    """The ids of the vehicle types (and type distributions) the traffic file defines; ConfigError unless it is a
    SUMO route file whose traffic departs until the warm-up and its snapshots end."""
    root = read_xml(traffic_file, "scenario.traffic_file")
    if root.tag != "routes":
        raise ConfigError(f"scenario.traffic_file {traffic_file} is not a SUMO route file (its root element is "
                          f"<{root.tag}>, not <routes>)")
    needed_s = scenario.warmup_s + scenario.snapshots * scenario.snapshot_interval_s
    last_s = max((_last_departure_s(element) for element in root), default=-1.0)
    if last_s < needed_s:
        ends = "has no vehicles or flows" if last_s < 0 else f"departs its last vehicle at {last_s:g} s"
        raise ConfigError(f"scenario.traffic_file {traffic_file.name} {ends}, before the warm-up and its snapshots "
                          f"end at {needed_s:g} s, so the road would be empty: let its flows run until then")
    return {element.get("id", "") for element in root if element.tag in ("vType", "vTypeDistribution")}


def _last_departure_s(element: ElementTree.Element) -> float:
    """When a vehicle, trip or flow departs its last vehicle [s]; -1 for other elements."""
    if element.tag in ("vehicle", "trip", "person"):
        return _seconds(element.get("depart", "0"))
    if element.tag != "flow":
        return -1.0
    if "end" in element.attrib:
        return _seconds(element.get("end", "0"))
    number, begin = element.get("number"), _seconds(element.get("begin", "0"))
    if number is None:
        return FLOW_DEFAULT_END_S
    for key, per_vehicle in (("period", 1.0), ("vehsPerHour", -3600.0), ("perHour", -3600.0)):
        value = element.get(key, "")
        try:
            rate = float(value)
        except ValueError:
            continue
        headway_s = rate if per_vehicle > 0 else -per_vehicle / rate if rate > 0 else 0.0
        return begin + float(number) * headway_s
    return FLOW_DEFAULT_END_S  # a random (exp() or probability) flow: its end is not known beforehand


def _seconds(value: str) -> float:
    """A SUMO time ("12.5", or "triggered" and the like: 0) [s]."""
    try:
        return float(value)
    except ValueError:
        return 0.0
