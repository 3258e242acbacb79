import math

import numpy as np
import pytest

from sumo_rail.config import Config
from sumo_rail.sim import kernels, lidar
from sumo_rail.sim.observation import build_observation

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
    return kernels.observation_vector(front_xy, heading, length, width, speed, packed, np.array(ego), lane, changing,
                                      CONFIG.lidar.beams, CONFIG.lidar.range_m, CONFIG.env.v_min_mps,
                                      CONFIG.env.v_max_mps, CONFIG.scenario.lanes)


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


def test_jit_compiles_without_a_cache_where_numba_cannot_write_one():
    namespace: dict = {}
    exec(compile("def twice(x):\n    return 2 * x\n", "<generated>", "exec"), namespace)  # no source file to cache by
    twice = kernels.jit(namespace["twice"])
    assert twice(21) == 42 and twice._cache.cache_path is None
