"""Commanding the vehicles the env drives: an ego's cruise set-point, commanded accelerations and lane changes, its
size, and handing a vehicle to SUMO's own models (`sumo_rail.sim.controllers`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sumo_rail.sim import network
from sumo_rail.sim.road import RouteMap
from sumo_rail.sim.sumo_api import (
    EGO_ID,
    LANE_CHANGE_MODE_TRACI_ONLY_SAFE,
    LANE_CHANGE_MODE_ZIP_MERGE,
    SPEED_MODE_COMMANDED_ACCELERATION,
    SimulationError,
)

LANE_CHANGE_MODE_SUMO = 1621
"""SUMO's default lane-change mode: a vehicle changes lanes as its lane-changing model decides."""


class EgoCommands:
    """The commanding part of `Simulation` (a mixin: `_api`, `_zip_merging`, `route_map`, `speed_limit_mps` and
    `forget_sizes` are the simulation's)."""

    _api: Any
    _zip_merging: set[str]
    """Egos whose lane-change mode is `LANE_CHANGE_MODE_ZIP_MERGE`."""
    route_map: RouteMap
    if TYPE_CHECKING:
        @property
        def speed_limit_mps(self) -> float: ...

        def forget_sizes(self, vehicle: str | None = None) -> None: ...

    def set_cruise_speed(self, speed_mps: float, vehicle: str = EGO_ID) -> None:
        """Set an ego's cruise set-point [m/s]; SUMO's ACC model tracks it within safe gaps.

        The set-point is the ego's desired speed, speed factor x speed limit. (Lowering the vehicle's maximum
        speed instead would be a hard cap that SUMO enforces at emergency deceleration, 9 m/s^2; a lower speed
        factor is reached at the ego type's comfortable deceleration.)
        """
        self._api.vehicle.setSpeedFactor(vehicle, speed_mps / self.speed_limit_mps)

    def take_acceleration_control(self, vehicle: str, max_acceleration_mps2: float) -> None:
        """Drive an ego by commanded accelerations (`set_acceleration`) from now on: its type becomes the
        acceleration interface's (`ACCELERATION_EGO_TYPE`: Krauss without dawdling, whose safe speed is the
        emergency brake), its desired speed its type's top speed, whatever the road's limit, its acceleration
        capability `max_acceleration_mps2` [m/s^2]; the speed mode keeps the safe speed and drops the bound on
        deceleration, so a commanded braking is followed as given. The vehicle keeps its length and width (a recorded
        seat's)."""
        vehicle_api = self._api.vehicle
        length_m, width_m = vehicle_api.getLength(vehicle), vehicle_api.getWidth(vehicle)
        vehicle_api.setType(vehicle, network.ACCELERATION_EGO_TYPE)
        vehicle_api.setAccel(vehicle, max_acceleration_mps2)  # a type of the vehicle's own: set before its speed factor
        vehicle_api.setLength(vehicle, length_m)
        vehicle_api.setWidth(vehicle, width_m)
        vehicle_api.setSpeedFactor(vehicle, vehicle_api.getMaxSpeed(vehicle) / self.speed_limit_mps)
        vehicle_api.setSpeedMode(vehicle, SPEED_MODE_COMMANDED_ACCELERATION)

    def set_acceleration(self, acceleration_mps2: float, duration_s: float, vehicle: str = EGO_ID) -> None:
        """Hold an ego's acceleration at `acceleration_mps2` [m/s^2] for `duration_s` [s] (a vehicle under
        `take_acceleration_control`); SUMO's safe speed brakes harder where the leader demands it, and the speed stays
        between 0 and the ego's top speed."""
        self._api.vehicle.setAcceleration(vehicle, acceleration_mps2, duration_s)

    def request_lane_change(self, lane: int, duration_s: float, vehicle: str = EGO_ID, zip_merge: bool = False) -> None:
        """Ask SUMO to move an ego to route lane `lane` when safe within `duration_s`; unsafe changes wait, never
        forced. A `zip_merge` (out of a lane about to end, `route_progress.zip_merge_change`) needs only that no
        collision is immediate, as SUMO's own drivers merge at a lane's end: the followers brake for it."""
        if not self.route_map.single_edge:
            lane = self.route_map.sumo_lane(self._api.vehicle.getLaneID(vehicle), lane)
        if zip_merge != (vehicle in self._zip_merging):
            self._zip_merging ^= {vehicle}
            mode = LANE_CHANGE_MODE_ZIP_MERGE if zip_merge else LANE_CHANGE_MODE_TRACI_ONLY_SAFE
            self._api.vehicle.setLaneChangeMode(vehicle, mode)
        self._api.vehicle.changeLane(vehicle, lane, duration_s)

    def resize(self, vehicle: str, length_m: float, width_m: float) -> None:
        """Give `vehicle` a length and width [m] of its own (a recorded seat's)."""
        self._api.vehicle.setLength(vehicle, length_m)
        self._api.vehicle.setWidth(vehicle, width_m)
        self.forget_sizes(vehicle)

    def hand_to_sumo(self, vehicle: str, type_id: str, desired_mps: float) -> None:
        """Let SUMO's own models drive `vehicle` from now on: the vehicle type `type_id` (its car following and lane
        changing; a type of the running routes), SUMO's default lane-change mode, desired speed `desired_mps` [m/s];
        the vehicle keeps its length, width and vehicle class."""
        vehicle_api = self._api.vehicle
        if type_id not in self._api.vehicletype.getIDList():
            raise SimulationError(f"SUMO's own driver needs vehicle type {type_id}, which this simulation's routes do "
                                  f"not define (a recorded scene's traffic brings it)")
        length_m, width_m = vehicle_api.getLength(vehicle), vehicle_api.getWidth(vehicle)
        vehicle_class = vehicle_api.getVehicleClass(vehicle)
        vehicle_api.setType(vehicle, type_id)
        self.resize(vehicle, length_m, width_m)  # a new type brings its own size and class
        if vehicle_api.getVehicleClass(vehicle) != vehicle_class:  # a truck's seat stays a truck's
            vehicle_api.setVehicleClass(vehicle, vehicle_class)
        vehicle_api.setLaneChangeMode(vehicle, LANE_CHANGE_MODE_SUMO)
        vehicle_api.setSpeedFactor(vehicle, desired_mps / self.speed_limit_mps)
