import dataclasses
import math

import numpy as np
import pytest
from scenes import EGO_FRONT, view

from sumo_rail.config import Config
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.observation import build_observation
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.route_progress import route_block
from sumo_rail.sim.traffic import lane_block

CONFIG = Config()


def numpy_observation(front_xy, heading, length, width, speed, segments, ego, lane, changing):
    """What the environment computed before the kernel: numpy LIDAR scan, then the observation."""
    front_x, front_y, ego_heading, ego_length, ego_speed, set_point = ego
    cos_h, sin_h = math.cos(ego_heading), math.sin(ego_heading)
    centre = np.array([front_x - 0.5 * ego_length * cos_h, front_y - 0.5 * ego_length * sin_h])
    boxes = lidar.stack(lidar.Boxes.from_front(front_xy, heading, length, width, speed), lidar.edge_boxes(segments))
    distances, relative = lidar.scan(centre, ego_heading, ego_speed * np.array([cos_h, sin_h]), boxes,
                                     CONFIG.lidar.beams, CONFIG.lidar.range_m)
    return build_observation(CONFIG, distances, relative, ego_speed, set_point, lane, changing)


def compiled_observation(front_xy, heading, length, width, speed, segments, ego, lane, changing):
    edges = lidar.edge_boxes(segments)
    packed = np.hstack([edges.centre_xy, edges.axis_xy, edges.half_size_m])
    count = len(heading)
    return kernels.observation_vector(front_xy, heading, length, width, speed, np.zeros(count),
                                      np.zeros(count, dtype=np.int64), packed, *ego, 0.0, lane, changing,
                                      CONFIG.lidar.beams, CONFIG.lidar.range_m, CONFIG.env.v_min_mps,
                                      CONFIG.env.v_max_mps, CONFIG.scenario.lanes, False, False, 1.0, 0.0, 1.0, 1.0)


def random_scene(rng: np.random.Generator, vehicles: int):
    """Vehicles around an ego on a gently curved five-lane road, as rows sliced like `Simulation.observe` does."""
    rows = np.empty((vehicles, 8))
    rows[:, 0] = rng.uniform(-100.0, 100.0, vehicles)
    rows[:, 1] = rng.uniform(-9.0, 9.0, vehicles)
    rows[:, 2] = rng.normal(0.0, 0.05, vehicles) + rng.choice([0.0, math.pi / 2], vehicles, p=[0.9, 0.1])
    rows[:, 3] = rng.uniform(0.0, 40.0, vehicles)
    rows[:, 5] = rng.uniform(3.0, 18.0, vehicles)
    rows[:, 6] = rng.uniform(1.6, 2.6, vehicles)
    x = np.linspace(-400.0, 400.0, 9)
    bend = rng.uniform(-1e-4, 1e-4) * x**2
    points = [np.stack([x, bend + offset], axis=1) for offset in (-10.0, 10.0)]
    segments = np.concatenate([np.stack([p[:-1], p[1:]], axis=1) for p in points])
    ego = (rng.uniform(-5.0, 5.0), rng.uniform(-8.0, 8.0), rng.normal(0.0, 0.05), rng.uniform(4.0, 16.0),
           rng.uniform(0.0, 40.0), rng.uniform(22.0, 33.0))
    return (rows[:, :2], rows[:, 2], rows[:, 5], rows[:, 6], rows[:, 3], segments, ego, int(rng.integers(5)),
            bool(rng.integers(2)))


@pytest.mark.parametrize("vehicles", [0, 1, 7, 40])
def test_kernel_matches_the_numpy_observation_on_random_scenes(vehicles):
    rng = np.random.default_rng(vehicles)
    exact = 0
    for _ in range(200):
        scene = random_scene(rng, vehicles)
        expected, got = numpy_observation(*scene), compiled_observation(*scene)
        assert got.dtype == np.float32 and got.shape == expected.shape
        np.testing.assert_array_max_ulp(got, expected, maxulp=1)
        exact += np.array_equal(got, expected)
    assert exact >= 190  # float32 rounding almost never tells them apart


def test_kernel_sees_a_car_ahead_and_a_box_around_the_sensor():
    no_edges = np.zeros((0, 2, 2))
    ego = (2.0, 0.0, 0.0, 4.0, 30.0, 30.0)  # centre at the origin, 30 m/s along +x
    ahead = (np.array([[24.0, 0.0]]), np.zeros(1), np.array([4.0]), np.array([2.0]), np.array([20.0]))
    observation = compiled_observation(*ahead, no_edges, ego, 2, False)
    beams, range_m, v_max = CONFIG.lidar.beams, CONFIG.lidar.range_m, CONFIG.env.v_max_mps
    assert observation[0] == np.float32(20.0 / range_m) and np.all(observation[1:beams] == 1.0)
    assert observation[beams] == np.float32(-10.0 / v_max) and np.all(observation[beams + 1:2 * beams] == 0.0)
    around = (np.array([[3.0, 0.0]]), np.zeros(1), np.array([6.0]), np.array([2.0]), np.array([30.0]))
    assert np.all(compiled_observation(*around, no_edges, ego, 2, True)[:beams] == 0.0)


def test_kernel_lane_and_route_blocks_are_the_python_blocks_bit_for_bit_on_random_scenes():
    rng = np.random.default_rng(3535)
    no_edges = np.zeros((0, 6))
    for _ in range(2000):
        count, lanes = int(rng.integers(0, 25)), int(rng.integers(1, 6))
        positions = EGO_FRONT + rng.uniform(-140.0, 140.0, count)
        if count and rng.random() < 0.3:  # equal positions: the first of equals is the nearest
            positions[rng.integers(0, count, count // 2)] = positions[0]
        others = [(int(rng.integers(-1, lanes + 1)), float(position), float(rng.choice([4.5, 7.5, 12.0, 16.5])),
                   float(rng.uniform(0.0, 40.0))) for position in positions]
        traffic = view(others, lane=int(rng.integers(-1, lanes)), speed=float(rng.uniform(0.0, 40.0)), lanes=lanes)
        neighbours = traffic.neighbours
        if count and rng.random() < 0.2:  # a vehicle on a road not linked to the route
            neighbours.lane_position_m[0], neighbours.lane[0] = -np.inf, -1000
        ends = tuple(float(end) for end in rng.choice([np.inf, 50.0, 300.0, 900.0], lanes))
        route = RouteView(0, lanes - 1, ends, float(rng.choice([np.inf, 80.0, 400.0])),
                          float(rng.choice([np.inf, 120.0, 700.0])), 2000.0)
        ego = dataclasses.replace(traffic.ego, route=route)
        range_m, v_max_mps, route_range_m = float(rng.choice([50.0, 100.0])), float(rng.choice([33.33, 36.0])), 500.0
        values = route_block(ego, route_range_m, lanes).astype(np.float64)
        got = kernels.observation_vector(
            neighbours.front_xy, neighbours.heading_rad, neighbours.length_m, neighbours.width_m, neighbours.speed_mps,
            neighbours.lane_position_m, neighbours.lane, no_edges, ego.front_x, ego.front_y, ego.heading_rad,
            ego.length_m, ego.speed_mps, 25.0, ego.lane_position_m, ego.lane, False, 8, range_m, 20.0, v_max_mps,
            lanes, True, True, *values)
        expected = np.concatenate([lane_block(traffic, range_m, v_max_mps), route_block(ego, route_range_m, lanes)])
        assert got.dtype == np.float32 and got[2 * 8 + 3 + lanes:].tobytes() == expected.tobytes()


def test_jit_compiles_without_a_cache_where_numba_cannot_write_one():
    namespace: dict = {}
    exec(compile("def twice(x):\n    return 2 * x\n", "<generated>", "exec"), namespace)  # no source file to cache by
    twice = kernels.jit(namespace["twice"])
    assert twice(21) == 42 and twice._cache.cache_path is None
