"""A recording of drivers whose rules no one here wrote: SUMO's own models (Krauss and IDM car following, LC2013
lane changing with three temperaments, sigma > 0, a spread of desired speeds, cars and trucks) on the project's
straight motorway, captured from libsumo at every step into the scene schema and written as a scene folder
(format "sumo")."""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from sumo_rail.config import ScenarioConfig
from sumo_rail.recordings.scene import TRACK_SCHEMA, SceneMeta
from sumo_rail.sim import network
from sumo_rail.sim.sumo_api import load_api, load_constants

DRIVER_TYPES = {
    # id: (vClass, carFollowModel, length [m], lcSpeedGain, lcCooperative, lcAssertive, speedFactor distribution)
    "car_krauss_calm": ("passenger", "Krauss", 4.5, 0.5, 1.0, 1.0, "norm(1.0,0.08,0.8,1.2)"),
    "car_krauss_eager": ("passenger", "Krauss", 4.5, 3.0, 0.5, 2.0, "norm(1.1,0.1,0.8,1.3)"),
    "car_idm_calm": ("passenger", "IDM", 4.5, 1.0, 1.0, 1.0, "norm(0.95,0.08,0.7,1.2)"),
    "car_idm_eager": ("passenger", "IDM", 4.5, 2.0, 0.2, 1.5, "norm(1.05,0.1,0.8,1.3)"),
    "truck_krauss": ("truck", "Krauss", 12.0, 0.3, 1.0, 1.0, "norm(0.8,0.05,0.7,0.9)"),
}
"""Each driver type's vehicle class, car-following model, length and LC2013 temperament."""
SIGMA = 0.5
"""Driver imperfection of every type (Krauss' and IDM's sigma)."""
SPLIT_SHARES = (("train", 0.6), ("validation", 0.2), ("test", 0.2))


def _routes_xml(flow_veh_per_h: float, duration_s: float) -> str:
    """SUMO routes: one vType per `DRIVER_TYPES`, drawn by a vTypeDistribution, and one Poisson flow."""
    types = "\n".join(
        f'  <vType id="{name}" vClass="{vclass}" carFollowModel="{model}" length="{length}" sigma="{SIGMA}" '
        f'laneChangeModel="LC2013" lcSpeedGain="{gain}" lcCooperative="{coop}" lcAssertive="{assertive}" '
        f'speedFactor="{factor}" probability="{0.15 if vclass == "truck" else 0.2125}"/>'
        for name, (vclass, model, length, gain, coop, assertive, factor) in DRIVER_TYPES.items())
    rate_per_s = flow_veh_per_h / 3600.0
    return (f'<routes>\n<vTypeDistribution id="drivers">\n{types}\n</vTypeDistribution>\n'
            f'<route id="through" edges="{network.EDGE_ID}"/>\n'
            f'<flow id="f" type="drivers" route="through" begin="0" end="{duration_s}" period="exp({rate_per_s})" '
            f'departLane="random" departSpeed="desired"/>\n</routes>\n')


def drive(scenario: ScenarioConfig, duration_s: float, traffic_seed: int) -> pd.DataFrame:
    """Run SUMO's drivers on the straight road for `duration_s` [s] and return every vehicle's track at every step
    (TRACK_SCHEMA columns; vehicle ids carry the seed so tracks of several seeds never share one)."""
    built = network.build(scenario)
    api, tc = load_api("libsumo"), load_constants()
    variables = (tc.VAR_POSITION, tc.VAR_ANGLE, tc.VAR_SPEED, tc.VAR_ACCELERATION, tc.VAR_ROAD_ID,
                 tc.VAR_LANE_INDEX, tc.VAR_LANEPOSITION, tc.VAR_LENGTH, tc.VAR_WIDTH, tc.VAR_VEHICLECLASS)
    rows: list[tuple] = []
    with tempfile.TemporaryDirectory() as scratch:
        routes = Path(scratch) / "drivers.rou.xml"
        routes.write_text(_routes_xml(scenario.flow_veh_per_h, duration_s))
        api.start([network.sumo_binary("sumo"), "-n", str(built.net_file), "-r", str(routes),
                   "--step-length", str(scenario.step_length_s), "--seed", str(traffic_seed),
                   "--lanechange.duration", str(scenario.lane_change_duration_s), "--no-step-log", "true",
                   "--no-warnings", "true", "--collision.action", "none"])
        try:
            while api.simulation.getTime() < duration_s:
                api.simulation.step()
                for vehicle in api.simulation.getDepartedIDList():
                    api.vehicle.subscribe(vehicle, variables)
                time_s = api.simulation.getTime()
                for vehicle, values in api.vehicle.getAllSubscriptionResults().items():
                    x_m, y_m = values[tc.VAR_POSITION]
                    rows.append((f"s{traffic_seed}_{vehicle}", time_s, x_m, y_m, values[tc.VAR_ANGLE],
                                 values[tc.VAR_SPEED], values[tc.VAR_ACCELERATION], values[tc.VAR_ROAD_ID],
                                 values[tc.VAR_LANE_INDEX], values[tc.VAR_LANEPOSITION], values[tc.VAR_LENGTH],
                                 values[tc.VAR_WIDTH], "truck" if values[tc.VAR_VEHICLECLASS] == "truck"
                                 else "passenger"))
        finally:
            api.close()
    frame = pd.DataFrame(rows, columns=TRACK_SCHEMA.names)
    return frame[~frame["edge"].str.startswith(":")].reset_index(drop=True)


def split_by_vehicle(vehicle_ids: list[str], seed: int) -> pd.DataFrame:
    """vehicle_id -> train / validation / test, a seeded shuffle in SPLIT_SHARES' proportions."""
    order = np.random.default_rng(seed).permutation(sorted(vehicle_ids))
    bounds = np.cumsum([0] + [round(share * len(order)) for _, share in SPLIT_SHARES[:-1]] + [len(order)])
    bounds[-1] = len(order)
    parts = [name for name, _ in SPLIT_SHARES]
    split = [parts[min(np.searchsorted(bounds, i, side="right") - 1, len(parts) - 1)] for i in range(len(order))]
    return pd.DataFrame({"vehicle_id": order.tolist(), "split": split})


def write_scene(folder: Path, scenario: ScenarioConfig, duration_s: float, traffic_seeds: list[int]) -> SceneMeta:
    """Drive every seed, write the scene folder (tracks.parquet, split.parquet, scene.json, road.net.xml); the
    folder is written aside and renamed into place, so it is whole or absent."""
    tracks = pd.concat([drive(scenario, duration_s, seed) for seed in traffic_seeds], ignore_index=True)
    folder = Path(folder)
    meta = SceneMeta(format="sumo", frame_rate_hz=1.0 / scenario.step_length_s, network="road.net.xml",
                     lanes=scenario.lanes,
                     settings={"duration_s": duration_s, "traffic_seeds": list(traffic_seeds), "sigma": SIGMA,
                               "driver_types": {k: list(v) for k, v in DRIVER_TYPES.items()},
                               "scenario": asdict(scenario)})
    folder.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=folder.parent, prefix=f".{folder.name}.") as scratch:
        staging = Path(scratch) / "scene"
        staging.mkdir()
        pq.write_table(pa.Table.from_pandas(tracks, schema=TRACK_SCHEMA, preserve_index=False),
                       staging / "tracks.parquet")
        split = split_by_vehicle(tracks["vehicle_id"].unique().tolist(), traffic_seeds[0])
        pq.write_table(pa.Table.from_pandas(split, preserve_index=False), staging / "split.parquet")
        shutil.copyfile(network.build(scenario).net_file, staging / "road.net.xml")
        (staging / "scene.json").write_text(json.dumps(asdict(meta), indent=1, sort_keys=True))
        if folder.exists():
            shutil.rmtree(folder)
        staging.rename(folder)
    return meta
