import math

import numpy as np
import pytest

from sumo_rail.sim.lidar import Boxes, edge_boxes, scan, stack

BEAMS, RANGE = 24, 100.0
ORIGIN = np.zeros(2)
EGO_VELOCITY = np.array([30.0, 0.0])


def boxes(*specs):
    """Each spec: (centre_x, centre_y, heading_rad, length, width, speed along heading)."""
    rows = np.array(specs, dtype=float).reshape(-1, 6)
    return Boxes.from_centre(rows[:, :2], rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5])


def run(box_set, edges=None, heading=0.0, velocity=EGO_VELOCITY):
    obstacles = box_set if edges is None else stack(box_set, edge_boxes(edges))
    return scan(ORIGIN, heading, velocity, obstacles, BEAMS, RANGE)


def test_car_straight_ahead_only_on_beam_zero():
    distance, relative = run(boxes((20.0, 0.0, 0.0, 4.0, 2.0, 20.0)))
    assert distance[0] == pytest.approx(18.0)
    assert relative[0] == pytest.approx(-10.0)
    assert np.all(distance[1:] == RANGE) and np.all(relative[1:] == 0.0)


def test_car_centred_on_beam_boundary_is_seen_by_the_beam_that_crosses_it():
    # Centre exactly on the 7.5 degree boundary between beams 0 and 1, 10 m away.
    centre = 10.0 * np.array([math.cos(math.radians(7.5)), math.sin(math.radians(7.5))])
    distance, _ = run(boxes((*centre, 0.0, 4.5, 1.8, 30.0)))
    rear_x = centre[0] - 2.25
    assert rear_x * math.tan(math.radians(15)) <= centre[1] + 0.9  # beam 1 enters through the rear face
    assert distance[1] == pytest.approx(rear_x / math.cos(math.radians(15)))
    assert distance[0] == RANGE  # beam 0 passes below the car (its lowest y is 0.405 m)


def test_beam_grazing_a_box_side_exactly_counts_as_a_hit():
    distance, _ = run(boxes((10.0, 0.9, 0.0, 4.5, 1.8, 30.0)))
    assert distance[0] == pytest.approx(7.75)


def test_two_cars_on_one_beam_nearest_wins():
    distance, relative = run(boxes((40.0, 0.0, 0.0, 4.0, 2.0, 35.0), (15.0, 0.0, 0.0, 4.0, 2.0, 25.0)))
    assert distance[0] == pytest.approx(13.0)
    assert relative[0] == pytest.approx(-5.0)


def test_truck_alongside_on_the_left():
    distance, relative = run(boxes((0.0, 3.2, 0.0, 12.0, 2.5, 25.0)))
    near_face = 3.2 - 1.25
    for beam in range(2, 11):
        angle = math.radians(15 * beam)
        assert distance[beam] == pytest.approx(near_face / math.sin(angle)), beam
    assert distance[1] == RANGE and distance[11] == RANGE
    assert relative[6] == pytest.approx(0.0)
    assert relative[2] == pytest.approx(-5.0 * math.cos(math.radians(30)))


def test_nothing_in_range_reads_r_max():
    empty = boxes()
    distance, relative = run(empty)
    assert np.all(distance == RANGE) and np.all(relative == 0.0)
    distance, relative = run(boxes((150.0, 0.0, 0.0, 4.0, 2.0, 0.0)))
    assert np.all(distance == RANGE) and np.all(relative == 0.0)


def test_road_edges_are_hit_with_static_relative_speed():
    edges = np.array([[[-1000.0, -5.0], [1000.0, -5.0]], [[-1000.0, 11.0], [1000.0, 11.0]]])
    distance, relative = run(boxes(), edges)
    assert distance[18] == pytest.approx(5.0)
    assert distance[6] == pytest.approx(11.0)
    assert distance[21] == pytest.approx(5.0 / math.sin(math.radians(45)))
    assert relative[21] == pytest.approx(-30.0 * math.cos(math.radians(45)))
    assert distance[0] == RANGE and distance[12] == RANGE


def test_road_edges_and_a_car_nearest_wins():
    edges = np.array([[[-1000.0, -5.0], [1000.0, -5.0]]])
    distance, relative = run(boxes((0.0, -3.0, 0.0, 4.0, 2.0, 30.0)), edges)
    assert distance[18] == pytest.approx(2.0) and relative[18] == pytest.approx(0.0)


def test_beams_turn_with_the_ego_heading():
    distance, _ = run(boxes((0.0, 20.0, math.pi / 2, 4.0, 2.0, 0.0)), heading=math.pi / 2,
                      velocity=np.array([0.0, 30.0]))
    assert distance[0] == pytest.approx(18.0)
    assert distance[6] == RANGE


def test_origin_inside_a_box_reads_zero():
    distance, _ = run(boxes((1.0, 0.0, 0.0, 4.0, 2.0, 30.0)))
    assert np.all(distance == 0.0)


def test_boxes_from_front_bumper_positions():
    built = Boxes.from_front(np.array([[22.0, 5.0]]), np.array([math.pi / 2]), np.array([4.0]), np.array([2.0]),
                             np.array([10.0]))
    assert built.centre_xy[0] == pytest.approx([22.0, 3.0])
    assert built.velocity_xy[0] == pytest.approx([0.0, 10.0])
