"""The five high-level actions and the command each one gives the ego."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from sumo_rail.sim.records import quick_init


class Action(IntEnum):
    """Discrete actions, in the order of the action space."""

    KEEP = 0
    ACCELERATE = 1
    DECELERATE = 2
    LANE_LEFT = 3
    LANE_RIGHT = 4


@quick_init
@dataclass(frozen=True)
class Command:
    """What the ego is told for one decision period."""

    set_point_mps: float
    """Cruise set-point for SUMO's ACC model [m/s]."""
    target_lane: int | None
    """Lane to change to (0 = rightmost), or None to stay."""
    invalid: bool
    """The action was impossible (a lane change off the road) and does nothing."""


def command_for(action: Action, set_point_mps: float, lane: int, lanes: int, speed_step_mps: float,
                v_min_mps: float, v_max_mps: float, lowest_lane: int = 0) -> Command:
    """The command for `action` given the current set-point [m/s] and lane; the set-point stays in [v_min, v_max].
    The lanes beside the ego are `lowest_lane` to `lanes - 1` (route lanes: an acceleration lane is -1)."""
    if action is Action.ACCELERATE:
        return Command(min(set_point_mps + speed_step_mps, v_max_mps), None, False)
    if action is Action.DECELERATE:
        return Command(max(set_point_mps - speed_step_mps, v_min_mps), None, False)
    if action is Action.LANE_LEFT:
        return Command(set_point_mps, lane + 1, False) if lane + 1 < lanes else Command(set_point_mps, None, True)
    if action is Action.LANE_RIGHT:
        return Command(set_point_mps, lane - 1, False) if lane > lowest_lane else Command(set_point_mps, None, True)
    return Command(set_point_mps, None, False)
