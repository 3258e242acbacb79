import pytest

from sumo_rail.action_config import ActionConfig
from sumo_rail.sim.actions import Action, Lateral, acceleration_command, command_for

LIMITS = {"speed_step_mps": 2.0, "v_min_mps": 10.0, "v_max_mps": 30.0}


def test_action_order_is_keep_accelerate_decelerate_left_right():
    assert [a.name for a in Action] == ["KEEP", "ACCELERATE", "DECELERATE", "LANE_LEFT", "LANE_RIGHT"]
    assert [int(a) for a in Action] == [0, 1, 2, 3, 4]


@pytest.mark.parametrize(("action", "set_point", "expected"), [
    (Action.ACCELERATE, 20.0, 22.0), (Action.ACCELERATE, 29.0, 30.0),
    (Action.DECELERATE, 20.0, 18.0), (Action.DECELERATE, 11.0, 10.0), (Action.KEEP, 20.0, 20.0),
])
def test_set_point_moves_by_a_step_within_limits(action, set_point, expected):
    command = command_for(action, set_point, 2, 5, **LIMITS)
    assert command.set_point_mps == expected
    assert command.target_lane is None and not command.invalid


def test_lane_changes_target_the_neighbouring_lane():
    assert command_for(Action.LANE_LEFT, 20.0, 2, 5, **LIMITS).target_lane == 3
    assert command_for(Action.LANE_RIGHT, 20.0, 2, 5, **LIMITS).target_lane == 1


@pytest.mark.parametrize(("action", "lane"), [(Action.LANE_LEFT, 4), (Action.LANE_RIGHT, 0)])
def test_lane_change_off_the_road_does_nothing_and_is_invalid(action, lane):
    command = command_for(action, 20.0, lane, 5, **LIMITS)
    assert command.invalid and command.target_lane is None and command.set_point_mps == 20.0


@pytest.mark.parametrize(("action", "lane", "lowest_lane", "target"), [
    (Action.LANE_LEFT, 3, 0, 4), (Action.LANE_RIGHT, 1, 0, 0), (Action.LANE_RIGHT, 0, -1, -1),
])
def test_a_change_into_the_outermost_lane_is_valid(action, lane, lowest_lane, target):
    command = command_for(action, 20.0, lane, 5, **LIMITS, lowest_lane=lowest_lane)
    assert command.target_lane == target and not command.invalid


@pytest.mark.parametrize(("lateral", "lane", "target"), [
    (Lateral.LEFT, 2, 3), (Lateral.RIGHT, 2, 1), (Lateral.LEFT, 3, 4), (Lateral.RIGHT, 1, 0),
    (Lateral.LEFT, 4, None), (Lateral.RIGHT, 0, None), (Lateral.KEEP, 2, None),
])
def test_the_acceleration_interface_changes_lanes_as_the_paper_interface_does(lateral, lane, target):
    command = acceleration_command(3, lateral, ActionConfig(interface="acceleration"), lane, 5)
    assert command.target_lane == target
    assert command.invalid == (target is None and lateral is not Lateral.KEEP)
