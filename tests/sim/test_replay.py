"""The recorded vehicles as a running SUMO's traffic: who is in SUMO around the ego."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from sumo_rail.config import Config
from sumo_rail.recordings.road import ROAD_EDGE
from sumo_rail.recordings.scene import SceneMeta, split_table, write_scene_folder
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.recordings.tracks import Recording
from sumo_rail.sim import replay
from sumo_rail.sim.actions import Action
from sumo_rail.sim.ego import CONTEXT_MARGIN_M
from sumo_rail.sim.replay import REPLAY_RADIUS_M
from sumo_rail.sim.simulation import EGO_ID

CONFIG = Config.from_dict({"scenario": {"lanes": 3}, "env": {"max_episode_s": 10.0}})
LANE_Y = (-8.0, -4.8, -1.6)
"""Lane centres [m] of three 3.2 m lanes right of y = 0, rightmost first."""


def straight_scene(folder, vehicles: dict[str, tuple[float, float]], duration_s: float = 20.0) -> None:
    """A scene at 10 Hz on a 2 km road of three lanes: each vehicle (id -> front x at 0 s [m], speed [m/s]) a car
    driving at its constant speed in lane 1."""
    time = np.round(np.arange(0.0, duration_s + 1e-9, 0.1), 6)
    tracks = pd.concat([pd.DataFrame({
        "vehicle_id": vehicle, "source_id": vehicle, "frame": np.arange(len(time)), "time_s": time,
        "x_m": front_m + speed_mps * time, "y_m": LANE_Y[1], "heading_deg": 90.0, "speed_mps": speed_mps,
        "acceleration_mps2": 0.0, "edge": ROAD_EDGE, "lane": np.int16(1), "lane_position_m": front_m + speed_mps * time,
        "length_m": np.float32(4.5), "width_m": np.float32(1.8), "vehicle_class": "passenger"})
        for vehicle, (front_m, speed_mps) in vehicles.items()], ignore_index=True)
    meta = SceneMeta(format="sumo", frame_rate_hz=10.0, network="road.net.xml", lanes=3, settings={"split_seed": 0})
    write_scene_folder(folder, Recording(tracks, 10.0, 3, (3.2,) * 3, 2000.0), tracks, split_table(tracks, 0, 0.0, 0.0),
                       meta, Config())


@pytest.fixture(scope="module")
def far_leader(tmp_path_factory):
    """A car at 40 m/s and, 170 m ahead in its lane, a slower one at 15 m/s (on the built road's limit, 44.44 m/s,
    which the scene's env drives at)."""
    folder = tmp_path_factory.mktemp("far_leader") / "scene"
    straight_scene(folder, {"car": (100.0, 40.0), "leader": (270.0, 15.0)})
    env = SceneEnv(CONFIG, folder, reactive=False)
    yield env
    env.close()


def test_a_leader_within_the_egos_braking_distance_is_in_the_replay(far_leader):
    """The replay radius is wide enough for SUMO's leader search (the ego's car following), which looks as far as
    the ego's braking distance: the slower car 170 m ahead is farther than the LIDAR sees but is the ego's leader."""
    far_leader.reset(seed=0, options={"vehicle": "car", "start_s": 1.0})
    vehicle = far_leader.simulation._api.vehicle
    speed_mps = vehicle.getSpeed(EGO_ID)
    braking_m = speed_mps ** 2 / (2 * vehicle.getDecel(EGO_ID)) + vehicle.getTau(EGO_ID) * speed_mps
    leader, gap_m = vehicle.getLeader(EGO_ID, 0.0)
    assert leader == "leader" and CONFIG.lidar.range_m + CONTEXT_MARGIN_M < gap_m < braking_m


def test_sumos_car_following_in_the_seat_reacts_to_a_leader_beyond_the_lidar_as_with_every_vehicle_in_sumo(
        far_leader, monkeypatch):
    """SUMO's IDM in the seat closes on the slower car 170 m ahead: it eases off from the start, and drives exactly as
    with every recorded vehicle in SUMO (an unbounded radius)."""
    runs = []
    for radius_m in (REPLAY_RADIUS_M, 1e9):
        monkeypatch.setattr(replay, "REPLAY_RADIUS_M", radius_m)
        far_leader.reset(seed=0, options={"vehicle": "car", "start_s": 1.0, "controller": "sumo"})
        runs.append([far_leader.step(int(Action.KEEP))[4]["speed_mps"] for _ in range(8)])
    assert runs[0] == runs[1]
    assert max(runs[0]) < 40.0 + 0.5 and runs[0][-1] < runs[0][0]
