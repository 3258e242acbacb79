"""The ego's action interfaces and the command each action gives: the paper's five high-level actions (`Action`,
`command_for`) and the acceleration interface (an acceleration bin and a `Lateral`, `acceleration_command`)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from gymnasium import spaces

from sumo_rail.action_config import ActionConfig
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
        return Command(set_point_mps, *_lane_change(+1, lane, lanes, lowest_lane))
    if action is Action.LANE_RIGHT:
        return Command(set_point_mps, *_lane_change(-1, lane, lanes, lowest_lane))
    return Command(set_point_mps, None, False)


def _lane_change(direction: int, lane: int, lanes: int, lowest_lane: int) -> tuple[int | None, bool]:
    """(target lane, invalid) of a change `direction` (+1 left, -1 right) from `lane`: invalid, with no target, left of
    lane `lanes - 1` or right of `lowest_lane` (a change toward the lanes is valid from a lane outside them)."""
    target = lane + direction
    return (target, False) if (target < lanes if direction > 0 else target >= lowest_lane) else (None, True)


class Lateral(IntEnum):
    """The acceleration interface's lane decision (`acceleration_action`)."""

    KEEP = 0
    LEFT = 1
    RIGHT = 2


@quick_init
@dataclass(frozen=True)
class AccelerationCommand:
    """What the ego is told for one decision period under the acceleration interface."""

    acceleration_mps2: float
    """Longitudinal acceleration for the period [m/s^2] (SUMO's safe speed may brake harder)."""
    target_lane: int | None
    """Lane to change to (0 = rightmost), or None to stay."""
    invalid: bool
    """The lane change was impossible (off the road) and does nothing."""


def action_space_of(actions: ActionConfig) -> spaces.Discrete:
    """The action space of an interface: Discrete(5), the paper's `Action`, or Discrete(3 x bins), an acceleration
    bin and a `Lateral` in one integer (`acceleration_action`), so that every learner, dataset and driver of the
    paper's integer actions takes the acceleration interface's unchanged."""
    if actions.interface == "acceleration":
        return spaces.Discrete(len(Lateral) * actions.acceleration_bins)
    return spaces.Discrete(len(Action))


def action_count(actions: ActionConfig) -> int:
    """How many actions the interface `actions` has (`action_space_of`'s n)."""
    return int(action_space_of(actions).n)


def acceleration_action(acceleration_bin: int, lateral: Lateral, actions: ActionConfig) -> int:
    """The acceleration interface's action of an acceleration bin (0 the lowest) and a lane decision: lateral x bins
    + bin, so the actions below `bins` keep the lane and are the bins themselves."""
    return int(lateral) * actions.acceleration_bins + acceleration_bin


def split_acceleration_action(action: int, actions: ActionConfig) -> tuple[int, Lateral]:
    """(acceleration bin, lane decision) of an acceleration-interface action (the inverse of `acceleration_action`)."""
    lateral, acceleration_bin = divmod(action, actions.acceleration_bins)
    return acceleration_bin, Lateral(lateral)


def acceleration_command(acceleration_bin: int, lateral: Lateral, actions: ActionConfig, lane: int, lanes: int,
                         lowest_lane: int = 0) -> AccelerationCommand:
    """The command of an acceleration-interface action; the lanes beside the ego are `lowest_lane` to `lanes - 1`."""
    acceleration = actions.acceleration_mps2(acceleration_bin)
    if lateral is Lateral.KEEP:
        return AccelerationCommand(acceleration, None, False)
    return AccelerationCommand(acceleration, *_lane_change(+1 if lateral is Lateral.LEFT else -1, lane, lanes,
                                                            lowest_lane))


def paper_equivalent(acceleration_mps2: float, lateral: Lateral) -> Action:
    """How an acceleration-interface action counts among the paper's five in an episode's action counts: a lane
    change as itself, else accelerate, decelerate or keep by the sign of the acceleration."""
    if lateral is not Lateral.KEEP:
        return Action.LANE_LEFT if lateral is Lateral.LEFT else Action.LANE_RIGHT
    if acceleration_mps2 == 0.0:
        return Action.KEEP
    return Action.ACCELERATE if acceleration_mps2 > 0.0 else Action.DECELERATE


def keep_action(actions: ActionConfig) -> int:
    """The action that changes nothing: the paper's keep, or an acceleration of 0 in the lane (holding the speed)."""
    if actions.interface == "acceleration":
        return acceleration_action(actions.nearest_bin(0.0), Lateral.KEEP, actions)
    return int(Action.KEEP)


def paper_action(action: int, actions: ActionConfig) -> Action:
    """The paper action an action of the interface `actions` counts as: itself, or an acceleration-interface action's
    `paper_equivalent`."""
    if actions.interface == "acceleration":
        acceleration_bin, lateral = split_acceleration_action(action, actions)
        return paper_equivalent(actions.acceleration_mps2(acceleration_bin), lateral)
    return Action(action)
