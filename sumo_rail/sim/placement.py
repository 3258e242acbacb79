"""Putting egos on the road: queued for SUMO's insertion at a reset, or placed at once between two steps (a
respawning ego). Egos start on the first edge of their route; lanes here are SUMO's indices on that edge."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from sumo_rail.sim import network
from sumo_rail.sim.sumo_api import LANE_CHANGE_MODE_TRACI_ONLY_SAFE

REACTION_S = 1.0
"""Reaction time in `EgoPlacement.place_ego`'s safety margins [s] (traffic acts every 0.5 s, with tau up to 1.2 s)."""
PLACE_MARGIN_M = 5.0
"""Extra distance in `EgoPlacement.place_ego`'s safety margins [m]."""


class EgoPlacement:
    """The placing part of `Simulation` (a mixin: `_api`, `_built` and `forget_sizes` are the simulation's)."""

    _api: Any
    _built: network.BuiltNetwork
    if TYPE_CHECKING:
        def forget_sizes(self, vehicle: str | None = None) -> None: ...

    @property
    def start_edge(self) -> str:
        """The edge egos start on: the first of their route."""
        return self._built.ego_route[0]

    @property
    def start_lanes(self) -> int:
        """Lanes of the start edge."""
        return self._api.edge.getLaneNumber(self.start_edge)

    @property
    def ego_length_m(self) -> float:
        """Length of an ego vehicle [m]."""
        return self._api.vehicletype.getLength(network.EGO_TYPE)

    def place_ego(self, vehicle: str, lane: int, position_m: float, max_speed_mps: float) -> bool:
        """Put a new ego on the road at once, between two steps, in `lane` of its start edge with its front at
        `position_m` [m], at the highest speed up to `max_speed_mps` (and up to what the lane allows the ego: a
        user's network may have a lower limit) that is safe there; False (and nothing placed) when none is.

        SUMO inserts a vehicle added now only at the next step; `vehicle.moveTo` forces it in at once, skipping
        SUMO's insertion checks, so they are made here. No vehicle may overlap the place (vehicles changing into or
        out of `lane` count as in it). The gap to the leader (beyond the ego's minimum gap) must exceed what the ego
        covers in `REACTION_S` plus `PLACE_MARGIN_M`, and that plus the ego's braking distance at its type's
        deceleration minus the leader's at its own; the follower's gap to the ego must exceed SUMO's secure gap for
        the follower (`getSecureGap`; for an ego follower, whose ACC model's is smaller, the same braking-distance
        difference) plus what it covers in `REACTION_S` and `PLACE_MARGIN_M`.
        """
        speed_mps = self._safe_speed(lane, position_m, max_speed_mps)
        if speed_mps is None:
            return False
        self.put_ego(vehicle, lane, position_m, speed_mps)
        return True

    def _safe_speed(self, lane: int, position_m: float, max_speed_mps: float) -> float | None:
        """The speed at which `place_ego` may place an ego at (`lane`, `position_m`) now; None where it may not."""
        api = self._api.vehicle
        ego_type = self._api.vehicletype
        ego_length_m, ego_min_gap_m = self.ego_length_m, ego_type.getMinGap(network.EGO_TYPE)
        ego_decel_mps2 = ego_type.getDecel(network.EGO_TYPE)
        ahead, behind = [], []
        for other, front_m, rear_m in self._lane_occupants(lane):
            if rear_m >= position_m:
                ahead.append((rear_m, other))
            elif front_m <= position_m - ego_length_m:
                behind.append((front_m, other))
            else:
                return None
        # SUMO refuses a departure speed above the ego's own limit on the lane (its type's speed factor, without spread)
        lane_limit_mps = self._api.lane.getMaxSpeed(f"{self.start_edge}_{lane}") * ego_type.getSpeedFactor(
            network.EGO_TYPE)
        speed_mps = min(max_speed_mps, lane_limit_mps, ego_type.getMaxSpeed(network.EGO_TYPE))
        if ahead:
            rear_m, leader = min(ahead)
            leader_speed = api.getSpeed(leader)
            gap_m = rear_m - position_m - ego_min_gap_m - PLACE_MARGIN_M
            if gap_m <= 0:
                return None
            # the largest v with gap >= v REACTION_S and gap >= v^2 / 2b - v_l^2 / 2b_l + v REACTION_S
            room_m = gap_m + leader_speed**2 / (2 * api.getDecel(leader))
            braking_mps = ego_decel_mps2 * (math.sqrt(REACTION_S**2 + 2 * room_m / ego_decel_mps2) - REACTION_S)
            speed_mps = min(speed_mps, gap_m / REACTION_S, braking_mps)
        if behind:
            front_m, follower = max(behind)
            follower_speed = api.getSpeed(follower)
            braking_m = follower_speed**2 / (2 * api.getDecel(follower)) - speed_mps**2 / (2 * ego_decel_mps2)
            secure_m = max(api.getSecureGap(follower, follower_speed, speed_mps, ego_decel_mps2), braking_m)
            gap_m = position_m - ego_length_m - front_m - api.getMinGap(follower)
            if gap_m < secure_m + follower_speed * REACTION_S + PLACE_MARGIN_M:
                return None
        return speed_mps

    def put_ego(self, vehicle: str, lane: int, position_m: float, speed_mps: float,
                route: tuple[str, ...] = (), edge: str = "") -> None:
        """Add an ego and move it onto the road at once, in `lane` of its start edge with its front at `position_m` [m]
        and speed `speed_mps` [m/s], skipping SUMO's insertion checks (`place_ego` makes them first; a recorded seat
        needs none). `route`: the ego's own route (edge ids; empty: the scenario's), whose first edge it starts on,
        or `edge` (a junction's, after the route's first edge)."""
        api, route_id = self._api.vehicle, self._built.route_id
        self.forget_sizes(vehicle)
        if route and route != self._built.ego_route:
            route_id = f"{vehicle}:{' '.join(route)}"
            if route_id not in self._api.route.getIDList():  # a load forgets the routes added since
                self._api.route.add(route_id, list(route))
        start = edge or (route[0] if route else self.start_edge)
        api.add(vehicle, route_id, typeID=network.EGO_TYPE, depart="now", departLane="0" if edge else str(lane),
                departPos=repr(position_m), departSpeed=repr(speed_mps))
        api.moveTo(vehicle, f"{start}_{lane}", position_m)
        api.setLaneChangeMode(vehicle, LANE_CHANGE_MODE_TRACI_ONLY_SAFE)

    def remove_ego(self, vehicle: str) -> None:
        """Take an ego off the road (one that failed standing at a lane's end would block the lane for the rest)."""
        self._api.vehicle.remove(vehicle)

    def _lane_occupants(self, lane: int) -> list[tuple[str, float, float]]:
        """(id, front, rear) [m along the start edge] of every vehicle in `lane` or changing into or out of it (off its
        lane's centre line)."""
        lanes, api = self._api.lane, self._api.vehicle
        edge = self.start_edge
        vehicles = list(lanes.getLastStepVehicleIDs(f"{edge}_{lane}"))
        for neighbour in (lane - 1, lane + 1):
            if 0 <= neighbour < self.start_lanes:
                vehicles += [vehicle for vehicle in lanes.getLastStepVehicleIDs(f"{edge}_{neighbour}")
                             if api.getLateralLanePosition(vehicle) != 0.0]
        occupants = []
        for vehicle in vehicles:
            front_m = api.getLanePosition(vehicle)
            occupants.append((vehicle, front_m, front_m - api.getLength(vehicle)))
        return occupants

    def _place_past_queue(self, pending: list[tuple[str, int, float]]) -> list[tuple[str, int, float]]:
        """Egos (vehicle id, lane, front position [m]) still waiting for SUMO's insertion after a step, less those
        placed now. SUMO tries vehicles in the order they came and no further vehicle in a lane once one failed
        there in the step: while traffic queues to enter the road at its start (a flow above what the start lets
        in; at 9000 veh/h on five lanes tens to hundreds wait), each queued vehicle failing in its random lane
        closes the lanes before SUMO gets to the egos, wherever they are and whatever room they have. So when at
        least as many vehicles as the start edge has lanes queue, each waiting ego whose place is safe now
        (`place_ego`'s rules, at the highest safe speed up to its own limit, as SUMO's departSpeed "max") is taken
        out of the queue and placed there; the others stay queued as they were. With a shorter queue (the usual
        flows, where a vehicle seldom waits at all) nothing changes: SUMO inserts the egos."""
        egos = {vehicle for vehicle, _, _ in pending}
        if len(set(self._api.simulation.getPendingVehicles()) - egos) < self.start_lanes:
            return pending
        waiting = []
        for vehicle, lane, position_m in pending:
            speed_mps = self._safe_speed(lane, position_m, math.inf)
            if speed_mps is None:
                waiting.append((vehicle, lane, position_m))
            else:
                self._api.vehicle.remove(vehicle)  # out of the insertion queue
                self.put_ego(vehicle, lane, position_m, speed_mps)
        return waiting

    def _insert(self, vehicle: str, lane: int, position_m: float) -> None:
        """Queue an ego for insertion now in `lane` of its start edge with its front at `position_m` [m], at the highest
        safe speed."""
        self.forget_sizes(vehicle)
        self._api.vehicle.add(vehicle, self._built.route_id, typeID=network.EGO_TYPE, depart="now",
                              departLane=str(lane), departPos=repr(position_m), departSpeed="max")
        self._api.vehicle.setLaneChangeMode(vehicle, LANE_CHANGE_MODE_TRACI_ONLY_SAFE)
