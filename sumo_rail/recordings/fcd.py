"""SUMO floating car data (`sumo --fcd-output`, https://sumo.dlr.de/docs/Simulation/Output/FCDOutput.html): read
into a scene on the user's network, and write a scene out.

The file (.xml, or .xml.gz) is `<fcd-export>` with one `<timestep time=...>` per output step holding a `<vehicle>`
per vehicle: id, x, y (the front bumper's centre [m]), angle (navigational [deg]), type, speed [m/s], pos (along the
lane [m]) and lane (SUMO's lane id, edge_index); acceleration, length and width are read where present (SUMO writes
acceleration with --fcd-output.acceleration; this module's writer writes all three). Without them the acceleration is
the change of speed per step and the size is the vehicle type's (the user's, the package's own or SUMO's built-in
types; a type without a size takes SUMO's default for its vClass, an unknown type SUMO's 5 m x 1.8 m car). Vehicles
whose vClass is not a motor vehicle's (a bicycle, SUMO's DEFAULT_BIKETYPE) are left out, said in a note. It is parsed
as a stream; persons and containers are skipped. Every lane must be in the network and
every vehicle on the lane it names (its front within half the lane's width + LANE_TOLERANCE_M of the lane's centre
line, its pos within the edge's length), or the recording was made on another network; speeds lie in [0, 100] m/s.
"""

from __future__ import annotations

import gzip
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping
from pathlib import Path
from typing import IO, cast
from xml.sax.saxutils import quoteattr

import numpy as np
import pandas as pd

from sumo_rail.recordings.formats import ReadOptions
from sumo_rail.recordings.road import NetworkLanes, read_lanes
from sumo_rail.recordings.tracks import (
    LANE_TOLERANCE_M,
    Recording,
    RecordingDataError,
    RecordingUsageError,
    check_limits,
)
from sumo_rail.sim.network import sources_dir
from sumo_rail.sim.scenarios import VEHICLE_TYPES_FILE

DEFAULT_SIZE_M = (5.0, 1.8)
"""SUMO's default vehicle type's length and width [m]."""
CLASS_SIZES_M = {"truck": (7.1, 2.4), "trailer": (16.5, 2.55), "bus": (12.0, 2.5), "coach": (14.0, 2.6),
                 "delivery": (6.5, 2.16), "emergency": (6.5, 2.16), "motorcycle": (2.2, 0.9), "moped": (2.1, 0.78),
                 "bicycle": (1.6, 0.65), "scooter": (1.2, 0.5), "pedestrian": (0.215, 0.478)}
"""SUMO's default length and width [m] of a vType of these vClasses that gives none (others: `DEFAULT_SIZE_M`)."""
SUMO_TYPES = {"DEFAULT_VEHTYPE": "passenger", "DEFAULT_TAXITYPE": "taxi", "DEFAULT_BIKETYPE": "bicycle",
              "DEFAULT_PEDTYPE": "pedestrian", "DEFAULT_RAILTYPE": "rail", "DEFAULT_CONTAINERTYPE": "container"}
"""SUMO's built-in vTypes and their vClasses."""
TRUCK_CLASSES = ("truck", "trailer", "bus", "coach")
MOTOR_CLASSES = frozenset({*TRUCK_CLASSES, "passenger", "private", "taxi", "evehicle", "army", "authority", "vip",
                           "hov", "delivery", "emergency", "motorcycle", "moped", "custom1", "custom2", "ignoring"})
"""The vClasses of motor vehicles on a road, which a scene keeps; the others (bicycle, pedestrian, scooter, tram,
rail, ship, ...) are left out of it."""
_REQUIRED = ("x", "y", "angle", "speed", "pos", "lane")
_TIME_TOLERANCE_S = 1e-6


def _open(path: Path) -> IO[bytes]:
    return cast(IO[bytes], gzip.open(path, "rb")) if str(path).endswith(".gz") else open(path, "rb")


def check_headers(files: list[Path]) -> None:
    """RecordingUsageError when a file is not SUMO FCD output (its root element is not fcd-export) or not XML."""
    for path in files:
        try:
            with _open(path) as file:
                _, root = next(iter(ElementTree.iterparse(file, events=("start",))))
        except (ElementTree.ParseError, OSError, EOFError, StopIteration) as error:
            raise RecordingUsageError(f"{path} is not SUMO FCD output: it is not readable XML ({error})") from error
        if root.tag != "fcd-export":
            raise RecordingUsageError(f"{path} is not SUMO FCD output: its root element is <{root.tag}>, not "
                                      f"<fcd-export>")


def _vehicle_types(given: Mapping[str, Mapping[str, str]]) -> dict[str, tuple[float, float, str]]:
    """SUMO's built-in vehicle types, the package's own and the `given` ones (the user's, which win): id -> (length,
    width [m], vClass), a size not given SUMO's default for the vClass."""
    root = ElementTree.fromstring((sources_dir() / VEHICLE_TYPES_FILE).read_bytes())
    attributes = {**{type_id: {"vClass": vehicle_class} for type_id, vehicle_class in SUMO_TYPES.items()},
                  **{vtype.get("id", ""): vtype.attrib for vtype in root.iter("vType")}, **given}
    types = {}
    for type_id, found in attributes.items():
        vehicle_class = found.get("vClass", "passenger")
        length, width = CLASS_SIZES_M.get(vehicle_class, DEFAULT_SIZE_M)
        types[type_id] = (float(found.get("length", length)), float(found.get("width", width)), vehicle_class)
    return types


def _motor_vehicles(columns: dict[str, list], known: list[tuple[float, float, str]]) -> str:
    """Leave the rows of vehicles whose vClass (`known`: each row's type's length, width, vClass) is not a motor
    vehicle's (`MOTOR_CLASSES`) out of `columns` and `known`, in place; the sentence saying which, or "" for none."""
    keep = [found[2] in MOTOR_CLASSES for found in known]
    if all(keep):
        return ""
    left = pd.DataFrame({"id": columns["id"], "vClass": [found[2] for found in known]})[
        [not kept for kept in keep]].drop_duplicates("id")
    counts = left["vClass"].value_counts(sort=False)
    for values in [*columns.values(), known]:
        values[:] = [value for value, kept in zip(values, keep, strict=True) if kept]
    return (f"{len(left)} vehicles that are not motor vehicles ({', '.join(f'{n} {c}' for c, n in counts.items())}; "
            f"the first {left['id'].iloc[0]}) are left out: a scene holds cars and trucks")


def read(files: list[Path], options: ReadOptions) -> Recording:
    """The vehicles of FCD `files` (one run, in time order across files) on the user's network `options.network`;
    DatasetError naming it when it is not a SUMO network."""
    if options.network is None:
        raise RecordingUsageError("FCD positions lie on the network they were recorded on; give it (--network)")
    network_path, network = options.network, read_lanes(options.network)
    columns: dict[str, list] = {name: [] for name in ("time", "id", "x", "y", "angle", "type", "speed", "pos", "lane",
                                                      "acceleration", "length", "width")}
    for path in files:
        _parse(path, columns)
    if not columns["id"]:
        raise RecordingDataError(f"{files[0]} holds no vehicle; the recording is empty")
    types = _vehicle_types(options.vtypes)
    known = [types.get(name, (*DEFAULT_SIZE_M, "passenger")) for name in columns["type"]]
    left_out = _motor_vehicles(columns, known)
    if not columns["id"]:
        raise RecordingDataError(f"{files[0]} holds no motor vehicle: {left_out}")
    time = np.asarray(columns["time"])
    steps = np.unique(time)
    step_s = round(float(np.min(np.diff(steps))), 6) if len(steps) > 1 else 1.0  # SUMO writes times to 0.01 s
    frame_float = (time - steps[0]) / step_s
    frame = np.rint(frame_float).astype(np.int64)
    uneven = np.abs(frame_float - frame) * step_s > _TIME_TOLERANCE_S + 1e-9 * np.abs(time)
    if uneven.any():
        raise RecordingDataError(f"{files[0]}: the timestep at {time[int(np.argmax(uneven))]:g} s is not a whole "
                                 f"number of {step_s:g} s steps after the first; the output steps are uneven")
    edge, lane = _lanes(columns, network, network_path)
    length = np.array([size[0] if value is None else value
                       for value, size in zip(columns["length"], known, strict=True)])
    width = np.array([size[1] if value is None else value for value, size in zip(columns["width"], known, strict=True)])
    vehicle_class = np.array(["truck" if size[2] in TRUCK_CLASSES or any(word in name.lower() for word in TRUCK_CLASSES)
                              else "passenger" for name, size in zip(columns["type"], known, strict=True)])
    tracks = pd.DataFrame({
        "vehicle_id": columns["id"], "source_id": columns["id"], "frame": frame, "time_s": time,
        "x_m": columns["x"], "y_m": columns["y"], "heading_deg": columns["angle"], "speed_mps": columns["speed"],
        "acceleration_mps2": np.array([np.nan if value is None else value for value in columns["acceleration"]]),
        "edge": edge, "lane": lane.astype(np.int16), "lane_position_m": columns["pos"],
        "length_m": length.astype(np.float32), "width_m": width.astype(np.float32), "vehicle_class": vehicle_class,
        "type": columns["type"]})
    check_limits(tracks, files[0], "speed", "length", by_time=True)
    _check_on_lanes(tracks, network, network_path, files[0])
    missing = tracks["acceleration_mps2"].isna().to_numpy()
    if missing.any():
        tracks = tracks.sort_values(["vehicle_id", "frame"], kind="stable", ignore_index=True)
        change = tracks.groupby("vehicle_id", sort=False)["speed_mps"].diff().shift(-1) / step_s
        tracks["acceleration_mps2"] = tracks["acceleration_mps2"].fillna(change).fillna(0.0)
    used = sorted(set(edge) - {name for name in set(edge) if name.startswith(":")})
    lanes = max((network.lanes(name) for name in used), default=1)
    notes = [f"positions on the network {network_path}; {len(used)} edges used", *filter(None, [left_out])]
    return Recording(tracks, 1.0 / step_s, lanes, (), 0.0, notes, tuple(files))


def _parse(path: Path, columns: dict[str, list]) -> None:
    """Append every vehicle row of FCD file `path` to `columns` (stream-parsed)."""
    time = 0.0
    try:
        with _open(path) as file:
            for event, element in ElementTree.iterparse(file, events=("start", "end")):
                if event == "start":
                    if element.tag == "timestep":
                        time = _number(element, "time", path, "timestep")
                    continue
                if element.tag == "vehicle":
                    _append(element, time, path, columns)
                    element.clear()
                elif element.tag == "timestep":
                    element.clear()
    except (ElementTree.ParseError, OSError, EOFError) as error:
        raise RecordingDataError(f"{path} is damaged: {error}") from error


def _number(element: ElementTree.Element, name: str, path: Path, what: str) -> float:
    raw = element.get(name)
    try:
        value = float(raw)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value):
        raise RecordingDataError(f"{path}: {what} has attribute {name}={raw!r}, not a number")
    return value


def _append(element: ElementTree.Element, time: float, path: Path, columns: dict[str, list]) -> None:
    vehicle = element.get("id", "")
    what = f"vehicle {vehicle} at {time:g} s"
    for name in _REQUIRED:
        if name not in element.attrib:
            raise RecordingDataError(f"{path}: {what} lacks the attribute {name!r} (SUMO writes it by default)")
    columns["time"].append(time)
    columns["id"].append(vehicle)
    for name in ("x", "y", "angle", "speed", "pos"):
        columns[name].append(_number(element, name, path, what))
    columns["lane"].append(element.get("lane", ""))
    columns["type"].append(element.get("type", ""))
    for name in ("acceleration", "length", "width"):
        columns[name].append(_number(element, name, path, what) if name in element.attrib else None)


def _lanes(columns: dict[str, list], network: NetworkLanes, network_path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Each row's edge and lane index; RecordingDataError naming the vehicle whose lane the network lacks."""
    lane_ids = np.asarray(columns["lane"])
    unique, inverse = np.unique(lane_ids, return_inverse=True)
    edges, indices = [], []
    for lane_id in unique:
        edge, _, index = str(lane_id).rpartition("_")
        if edge not in network.widths_m or not index.isdigit() or int(index) >= network.lanes(edge):
            row = int(np.argmax(lane_ids == lane_id))
            raise RecordingDataError(f"vehicle {columns['id'][row]} at {columns['time'][row]:g} s is on lane "
                                     f"{str(lane_id)!r}, which the network {network_path} does not have")
        edges.append(edge)
        indices.append(int(index))
    return np.asarray(edges, dtype=object)[inverse], np.asarray(indices)[inverse]


def _check_on_lanes(tracks: pd.DataFrame, network: NetworkLanes, network_path: Path, path: Path) -> None:
    """RecordingDataError naming the first vehicle whose front lies off the lane it names on the network: farther than
    half the lane's width plus LANE_TOLERANCE_M from its centre line, or a position along it (pos) outside its edge's
    length by more than that."""
    points = tracks[["x_m", "y_m"]].to_numpy(float)
    position = tracks["lane_position_m"].to_numpy(float)
    for (edge, index), rows in tracks.groupby(["edge", "lane"], sort=True).indices.items():
        lateral = _distance_m(points[rows], network.shapes_m[edge][index])
        width, length = network.widths_m[edge][index], network.lengths_m[edge]
        aside = lateral > width / 2 + LANE_TOLERANCE_M
        off = aside | (position[rows] < -LANE_TOLERANCE_M) | (position[rows] > length + LANE_TOLERANCE_M)
        if off.any():
            first = int(np.argmax(off))
            row = tracks.iloc[int(rows[first])]
            where = (f"{lateral[first]:.4g} m from the centre of lane {edge}_{index} ({width:.2f} m wide)"
                     if aside[first] else f"at pos {row['lane_position_m']:g} m of lane {edge}_{index} ({length:.1f} m "
                                          f"long)")
            geo = (np.abs(points[:, 0]).max() <= 180 and np.abs(points[:, 1]).max() <= 90
                   and np.abs(network.shapes_m[edge][index]).max() > 180)
            why = ("its x, y all look like longitude and latitude: written with --fcd-output.geo? import needs the "
                   "network's x, y" if geo else "the recording was not made on this network")
            raise RecordingDataError(f"{path}: vehicle {row['source_id']} at {row['time_s']:g} s lies {where} on the "
                                     f"network {network_path}: {why}")


def _distance_m(points: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Each point's distance [m] to the polyline `shape` ((P, 2) points [m]; infinite without a segment)."""
    if len(shape) < 2:
        return np.full(len(points), np.inf)
    start, along = shape[:-1], np.diff(shape, axis=0)
    relative = points[:, None, :] - start[None, :, :]
    share = np.clip(np.sum(relative * along, axis=2) / np.maximum(np.sum(along**2, axis=1), 1e-12), 0.0, 1.0)
    return np.min(np.hypot(*np.moveaxis(relative - share[:, :, None] * along[None, :, :], 2, 0)), axis=1)


def write(tracks: pd.DataFrame, path: Path, decimals: int = 2) -> Path:
    """Write `tracks` as SUMO FCD XML (gzip-compressed when `path` ends in .gz), with acceleration, length and
    width; the type is the vehicle class. Values carry `decimals` decimals (SUMO's default --precision 2)."""
    rows = tracks.sort_values(["time_s", "vehicle_id"], kind="stable")
    d = decimals
    with (gzip.open(path, "wt", encoding="utf-8") if str(path).endswith(".gz")
          else open(path, "w", encoding="utf-8")) as file:
        file.write('<?xml version="1.0" encoding="UTF-8"?>\n<fcd-export>\n')
        for time_s, step in rows.groupby("time_s", sort=True):
            file.write(f'    <timestep time="{time_s:.2f}">\n')
            for row in step.itertuples(index=False):
                file.write(f'        <vehicle id={quoteattr(str(row.vehicle_id))} x="{row.x_m:.{d}f}" '
                           f'y="{row.y_m:.{d}f}" angle="{row.heading_deg:.{d}f}" '
                           f'type={quoteattr(str(row.vehicle_class))} speed="{row.speed_mps:.{d}f}" '
                           f'pos="{row.lane_position_m:.{d}f}" lane={quoteattr(f"{row.edge}_{row.lane}")} '
                           f'slope="0.00" acceleration="{row.acceleration_mps2:.{d}f}" '
                           f'length="{row.length_m:.{d}f}" width="{row.width_m:.{d}f}"/>\n')
            file.write("    </timestep>\n")
        file.write("</fcd-export>\n")
    return path
