"""A recording of drivers no one here wrote: SUMO's own car-following and lane-changing models on a straight
motorway or on a network of the user's, captured at every step (the simulation's observer,
`sumo_rail.sim.observers.VehicleCapture`) and written as a scene folder (format "sumo").

The road is `road.build_road`'s straight edge (the scenario's lanes, lane width and length, as the package's own
straight highway; its speed limit `road.ROAD_SPEED_MPS`, as every built scene road's), or with scenario.kind network
the user's network (scenario.network, named in scene.json with its sha256, as an FCD scene's): there every edge no
edge leads into (a road's start, an on-ramp) from which the end of scenario.route can be reached gets a flow to it,
scenario.flow_veh_per_h for the widest such edge and in proportion to its lanes for the others. The traffic is a
Poisson flow of `DRIVER_TYPES`: cars and trucks, Krauss and IDM car following, LC2013 lane changing with
calm, eager and cooperative temperaments (lcSpeedGain, lcCooperative, lcAssertive), driver imperfection sigma > 0 and a
spread of desired speeds (a normal speedFactor per vehicle). After scenario.warmup_s [s] every vehicle on the road is
captured at every step for `duration_s` [s]: its front bumper's centre, heading, speed, acceleration, edge, lane and
position along it, size and class. The same seed gives the same bytes (SUMO's --seed; nothing else is random).
"""

from __future__ import annotations

import dataclasses
import tempfile
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from sumo_rail.config import Config, ConfigError, ScenarioConfig
from sumo_rail.datasets import file_sha256
from sumo_rail.recordings.formats import SUMO_DRIVERS
from sumo_rail.recordings.road import ROAD_EDGE, ROAD_SPEED_MPS, build_road, network_root
from sumo_rail.recordings.scene import SPLITS, SceneMeta, check_scene_output, split_table, write_scene_folder
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.tracks import Recording, RecordingDataError, RecordingUsageError, kept_tracks
from sumo_rail.sim import network
from sumo_rail.sim.built_network import BuiltNetwork
from sumo_rail.sim.net_file import NetFile
from sumo_rail.sim.observers import VehicleCapture
from sumo_rail.sim.simulation import Simulation
from sumo_rail.sim.traffic_source import GeneratedTraffic

_CAR = {"vClass": "passenger", "length": "4.5", "width": "1.8", "minGap": "2.5", "maxSpeed": "50.0", "accel": "2.6",
        "decel": "4.5", "emergencyDecel": "9.0"}
_TRUCK = {"vClass": "truck", "length": "12.0", "width": "2.5", "minGap": "3.0", "maxSpeed": "25.0", "accel": "1.1",
          "decel": "4.0", "emergencyDecel": "7.0"}
DRIVER_TYPES: dict[str, dict[str, str]] = {
    # Krauss: sigma dawdles; calm keeps right and cooperates, eager overtakes and squeezes in
    "car_krauss_calm": {**_CAR, "carFollowModel": "Krauss", "sigma": "0.5", "tau": "1.2", "lcSpeedGain": "0.7",
                        "lcCooperative": "1.0", "lcAssertive": "1.0", "speedFactor": "normc(0.95,0.08,0.7,1.2)",
                        "probability": "0.30"},
    "car_krauss_eager": {**_CAR, "carFollowModel": "Krauss", "sigma": "0.3", "tau": "0.8", "lcSpeedGain": "2.5",
                         "lcCooperative": "0.3", "lcAssertive": "2.0", "speedFactor": "normc(1.15,0.10,0.9,1.4)",
                         "accel": "3.2", "probability": "0.15"},
    # IDM: smooth following (delta 4); cooperative drivers let others in, eager ones overtake
    "car_idm_cooperative": {**_CAR, "carFollowModel": "IDM", "sigma": "0.2", "tau": "1.4", "lcSpeedGain": "1.0",
                            "lcCooperative": "1.0", "lcAssertive": "0.8", "speedFactor": "normc(1.0,0.10,0.7,1.3)",
                            "probability": "0.25"},
    "car_idm_eager": {**_CAR, "carFollowModel": "IDM", "sigma": "0.2", "tau": "0.9", "lcSpeedGain": "2.0",
                      "lcCooperative": "0.5", "lcAssertive": "1.5", "speedFactor": "normc(1.1,0.10,0.8,1.4)",
                      "probability": "0.15"},
    "truck_krauss": {**_TRUCK, "carFollowModel": "Krauss", "sigma": "0.5", "tau": "1.5", "lcSpeedGain": "0.3",
                     "lcCooperative": "1.0", "lcAssertive": "0.7", "lcKeepRight": "2.0",
                     "speedFactor": "normc(0.75,0.05,0.6,0.85)", "probability": "0.10"},
    "truck_idm": {**_TRUCK, "carFollowModel": "IDM", "sigma": "0.3", "tau": "1.6", "lcSpeedGain": "0.3",
                  "lcCooperative": "1.0", "lcAssertive": "0.7", "lcKeepRight": "2.0",
                  "speedFactor": "normc(0.75,0.05,0.6,0.85)", "probability": "0.05"},
}
"""The background drivers' SUMO vTypes (probability = share of arrivals; all LC2013, actionStepLength 0.5 s)."""


@dataclass(frozen=True)
class SumoDriversSettings:
    """What to record (the options of `sumo-rail record-sumo-drivers`)."""

    out: Path
    seed: int
    """SUMO's --seed: arrivals, types, desired speeds, dawdling."""
    duration_s: float = 600.0
    """Recorded time after the warm-up (scenario.warmup_s) [s]."""
    split_seed: int = 0
    test_share: float = 0.2
    validation_share: float = 0.1
    overwrite: bool = False


@dataclass(frozen=True)
class SumoDriversSummary:
    """What a recording holds."""

    tracks: int
    rows: int
    dropped: int
    split_counts: dict[str, int]
    types: dict[str, int]
    """Vehicles of each of `DRIVER_TYPES` among the kept tracks."""


def driver_type(type_id: str) -> dict[str, str]:
    """The vType attributes of `DRIVER_TYPES[type_id]` as the run defines it (its share of arrivals left out)."""
    return {"laneChangeModel": "LC2013", "actionStepLength": "0.5",
            **{key: value for key, value in DRIVER_TYPES[type_id].items() if key != "probability"}}


def routes_xml(flow_veh_per_h: float, entries: dict[str, float] | None = None, to_edge: str = "") -> bytes:
    """The routes file: `DRIVER_TYPES` as one distribution, flowing with Poisson arrivals along the built road, or
    (`entries`: edge -> veh/h) from each entry edge to `to_edge` on a user's network."""
    root = ElementTree.Element("routes")
    for type_id, attributes in DRIVER_TYPES.items():
        ElementTree.SubElement(root, "vType", id=type_id,
                               attrib={**driver_type(type_id), "probability": attributes["probability"]})
    ElementTree.SubElement(root, "vTypeDistribution", id="drivers", vTypes=" ".join(DRIVER_TYPES))
    if entries is None:
        ElementTree.SubElement(root, "route", id="road_route", edges=ROAD_EDGE)
        ElementTree.SubElement(root, "flow", id="drivers", route="road_route", type="drivers", begin="0", end="1e9",
                               period=f"exp({flow_veh_per_h / 3600.0!r})", departLane="random", departSpeed="max",
                               departPos="base")
    for entry, veh_per_h in (entries or {}).items():
        ElementTree.SubElement(root, "flow", attrib={
            "id": f"drivers_{entry}", "from": entry, "to": to_edge, "type": "drivers", "begin": "0", "end": "1e9",
            "period": f"exp({veh_per_h / 3600.0!r})", "departLane": "random", "departSpeed": "max",
            "departPos": "base"})
    return ElementTree.tostring(root)


def network_entries(scenario: ScenarioConfig) -> dict[str, float]:
    """The drivers' flows on a user's network (module docstring): entry edge -> veh/h."""
    net = NetFile(network_root(Path(scenario.network).expanduser().resolve()))
    target = scenario.route.split()[-1]
    reaching = [edge for edge in net.entries() if net.reaches(edge, target)]
    widest = max(net.edge.getLaneNumber(edge) for edge in reaching)
    return {edge: scenario.flow_veh_per_h * net.edge.getLaneNumber(edge) / widest for edge in reaching}


def _capture(config: Config, settings: SumoDriversSettings, net_file: Path, scratch: Path) -> pd.DataFrame:
    """Run SUMO on `net_file` with the drivers' routes and return every vehicle's rows after the warm-up (TRACK_COLUMNS,
    frame, source_id, type): a simulation whose traffic is the routes' own, watched at every step."""
    scenario = dataclasses.replace(config.scenario, traffic_seed=settings.seed)
    routes = scratch / "drivers.rou.xml"
    on_network = scenario.kind == "network"
    routes.write_bytes(routes_xml(scenario.flow_veh_per_h, network_entries(scenario), scenario.route.split()[-1])
                       if on_network else routes_xml(scenario.flow_veh_per_h))
    route = tuple(scenario.route.split()) if on_network else (ROAD_EDGE,)
    traffic = GeneratedTraffic(BuiltNetwork(net_file, routes, scratch, route))
    sim = Simulation(scenario, 0.0, transport="auto", traffic=traffic)
    step_s = scenario.step_length_s
    try:
        sim.advance(round(scenario.warmup_s / step_s))
        with sim.watching(VehicleCapture(every_step=True)) as capture:
            sim.advance(round(settings.duration_s / step_s))
    finally:
        sim.close()
    columns = capture.columns
    ids, frame = columns["vehicle_id"], np.asarray(columns["frame"], dtype=np.int64)
    return pd.DataFrame({
        "vehicle_id": ids, "source_id": ids, "frame": frame, "time_s": np.round(frame * step_s, 9),
        "x_m": columns["x_m"], "y_m": columns["y_m"], "heading_deg": columns["heading_deg"],
        "speed_mps": columns["speed_mps"], "acceleration_mps2": columns["acceleration_mps2"], "edge": columns["edge"],
        "lane": np.asarray(columns["lane"]).astype(np.int16),
        "lane_position_m": columns["lane_position_m"], "length_m": np.array(columns["length_m"], dtype=np.float32),
        "width_m": np.array(columns["width_m"], dtype=np.float32), "vehicle_class": columns["vehicle_class"],
        "type": columns["type"]})


def check_recording(settings: SumoDriversSettings, config: Config) -> None:
    """RecordingUsageError for anything wrong before work starts: the folder, a scene already in it, the shares, a
    road other than the straight one or a user's network (whose route is checked as every command checks it), a
    duration too short for one decision."""
    if config.scenario.kind not in ("straight", "network"):
        raise RecordingUsageError(f"record-sumo-drivers records on a straight road of scenario.lanes lanes or on your "
                                  f"network (scenario.kind network), not on scenario.kind {config.scenario.kind}")
    if config.scenario.kind == "network":
        try:
            network.check_user_route(config)
        except ConfigError as error:
            raise RecordingUsageError(str(error)) from error
    decision_s = config.env.decision_period_s + config.scenario.step_length_s
    if settings.duration_s < decision_s:
        raise RecordingUsageError(f"--duration-s {settings.duration_s:g} is shorter than one decision and the step "
                                  f"after it ({decision_s:g} s, env.decision_period_s + scenario.step_length_s), so no "
                                  f"track could be kept")
    check_scene_output(settings.out, settings.overwrite)
    if settings.test_share + settings.validation_share >= 1:
        raise RecordingUsageError("--test-share and --validation-share must leave vehicles to train")


def record_sumo_drivers(settings: SumoDriversSettings, config: Config) -> SumoDriversSummary:
    """Record `settings.duration_s` of SUMO's drivers and write the scene folder `settings.out`."""
    scenario = config.scenario
    on_network = scenario.kind == "network"
    widths = [] if on_network else [scenario.lane_width_m] * scenario.lanes
    user_net = Path(scenario.network).expanduser().resolve()
    with tempfile.TemporaryDirectory() as scratch:
        net_file = user_net if on_network else Path(scratch) / "road.net.xml"
        if not on_network:
            build_road(widths, scenario.length_m, net_file)
        rows = _capture(config, settings, net_file, Path(scratch))
    raise_more = "raise --duration-s, scenario.warmup_s or scenario.flow_veh_per_h"
    if rows.empty:
        raise RecordingDataError(f"no vehicle drove in the {settings.duration_s:g} s recorded; {raise_more}")
    rate_hz = 1.0 / scenario.step_length_s
    tracks, dropped = kept_tracks(rows, rate_hz, config.env.decision_period_s, "the SUMO run", gaps_fail=False)
    if tracks.empty:
        raise RecordingDataError(f"no vehicle of the {settings.duration_s:g} s recorded stayed on the road for one "
                                 f"decision (env.decision_period_s {config.env.decision_period_s:g} s) and the step "
                                 f"after it ({len(dropped)} too short); {raise_more}")
    split = split_table(tracks, settings.split_seed, settings.test_share, settings.validation_share)
    recorded = {key: (str(value) if isinstance(value, Path) else value)
                for key, value in dataclasses.asdict(settings).items() if key not in ("out", "overwrite")}
    recorded |= {"warmup_s": scenario.warmup_s, "flow_veh_per_h": scenario.flow_veh_per_h,
                 "decision_period_s": config.env.decision_period_s, "step_length_s": scenario.step_length_s,
                 "road_speed_mps": ROAD_SPEED_MPS, "driver_types": DRIVER_TYPES}
    if on_network:
        recorded |= {"road_speed_mps": scene_road(user_net).speed_limit_mps, "route": scenario.route}
    kinds = tracks.drop_duplicates("vehicle_id")
    meta = SceneMeta(format=SUMO_DRIVERS.name, frame_rate_hz=rate_hz,
                     network=str(user_net) if on_network else "road.net.xml", lanes=scenario.lanes,
                     sources={str(user_net): file_sha256(user_net)} if on_network else {}, dropped=dropped,
                     settings=recorded,
                     vehicle_types=dict(zip(kinds["vehicle_id"].astype(str), kinds["type"].astype(str), strict=True)),
                     vtypes={type_id: driver_type(type_id) for type_id in DRIVER_TYPES})
    recording = Recording(tracks, rate_hz, scenario.lanes, tuple(widths), scenario.length_m)
    write_scene_folder(settings.out, recording, tracks, split, meta, config)
    counts = pd.Series(split.column("split").to_pylist()).value_counts()
    types = tracks.drop_duplicates("vehicle_id")["type"].value_counts()
    return SumoDriversSummary(len(split), len(tracks), len(dropped),
                              {name: int(counts.get(name, 0)) for name in SPLITS},
                              {name: int(types.get(name, 0)) for name in DRIVER_TYPES})
