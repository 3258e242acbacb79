"""What the simulation reports about the vehicles it drives: an ego's state, its neighbours, and what happened to
an ego during one decision period. Plain data (no SUMO here); `sumo_rail.sim.simulation` fills them in."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sumo_rail.sim.records import quick_init
from sumo_rail.sim.road import RouteView

_LATERAL_EPSILON_M = 0.01


@quick_init
@dataclass(frozen=True)
class EgoState:
    """The ego at the end of the last step. Positions [m], speed [m/s], heading [rad, math convention]."""

    front_x: float
    front_y: float
    heading_rad: float
    speed_mps: float
    lane: int
    lane_position_m: float
    """Front-bumper position along the ego's route [m] (`sumo_rail.sim.road`)."""
    lateral_offset_m: float
    """Distance of the ego's centre from its lane's centre line [m]; non-zero only while changing lanes."""
    length_m: float
    width_m: float
    lane_id: str = field(default="", repr=False, compare=False)
    """SUMO's id of the lane the ego is in ("" where not known)."""
    route: RouteView | None = field(default=None, repr=False, compare=False)
    """What the ego knows of its route from where it is (None where not known)."""

    @property
    def changing_lane(self) -> bool:
        """The ego is between lanes (a lane change is under way)."""
        return abs(self.lateral_offset_m) > _LATERAL_EPSILON_M


@quick_init
@dataclass(frozen=True)
class Neighbours:
    """Vehicles around the ego (excluding it), from one context subscription; arrays have one row each."""

    ids: tuple[str, ...]
    front_xy: np.ndarray
    """Front-bumper centres [m], shape (M, 2)."""
    heading_rad: np.ndarray
    """Headings [rad], 0 = +x, counter-clockwise, shape (M,)."""
    speed_mps: np.ndarray
    lane_position_m: np.ndarray
    """Front-bumper position along the ego's route [m]; -inf for a vehicle on a road not linked to it."""
    length_m: np.ndarray
    width_m: np.ndarray
    lane: np.ndarray
    """Route lane (0 = the main road's rightmost; `sumo_rail.sim.road`), shape (M,) int."""


@quick_init
@dataclass(frozen=True)
class PeriodReport:
    """What happened to one ego during the SUMO steps of one decision period."""

    ego_collided: bool
    ego_left_network: bool
    ego_teleported: bool
    min_acceleration_mps2: float
    """Lowest acceleration of the ego over the period's steps [m/s^2] (0 when it left at the first step)."""
    teleports: int
    """Vehicles (any, the ego included) that started a teleport while the ego was on the road in this period."""
    left_at_s: float | None = None
    """Simulation time [s] at which the ego collided or left, when several egos share the simulation (the others
    drive on, so the clock has moved past it); None: read the simulation's clock."""
    accelerations_mps2: tuple[float, ...] = ()
    """The ego's acceleration at each step of the period while it was on the road [m/s^2]."""
    watched_min_acceleration_mps2: dict[str, float] = field(default_factory=dict)
    """Lowest acceleration over the period's steps [m/s^2] of each watched vehicle that was on the road
    (`sumo_rail.sim.period_safety`)."""
