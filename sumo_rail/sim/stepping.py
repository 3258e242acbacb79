"""Running a decision period: SUMO's steps, watching each ego for collisions, arrival, braking and teleports."""

from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Sequence
from typing import Any

from sumo_rail.sim.sumo_api import INVALID_VALUE, DecisionCalls, SimulationError
from sumo_rail.sim.traffic_source import TrafficSource
from sumo_rail.sim.vehicles import PeriodReport


class Stepping:
    """The stepping part of `Simulation` (a mixin: `_api`, `_calls`, `_client` and `traffic` are the simulation's)."""

    _api: Any
    _client: Any
    _calls: DecisionCalls
    """`sumo_api.decision_calls` of `_api`, found once per connection (its step: the traffic's, then the observers)."""
    traffic: TrafficSource
    clock_offset_s: float
    """The simulation's time less SUMO's clock [s]."""

    def advance_egos(self, steps: int, vehicles: Sequence[str], watch: Sequence[str] = ()) -> list[PeriodReport]:
        """Run `steps` SUMO steps, watching each ego of `vehicles` until it is gone; the steps go on while any of them
        is on the road. One report per ego, in order; an ego that is gone has the time it went (`left_at_s`) and the
        teleports until then; an ego the traffic saw collide (`TrafficSource.collided`: SUMO still answers for an ego
        that ran into a replayed vehicle in the period's last step, and leaves it at the next) collided. The other
        vehicles of `watch` have their lowest acceleration read while on the road (in every ego's report).

        Per step: the step, the teleport count, each ego's acceleration and each watched vehicle's (none, not SUMO's
        `INVALID_VALUE`, for one still waiting to be inserted). An ego is gone
        (collided, and so removed, or arrived) exactly when asking for its acceleration fails; only then are the
        step's collision and arrival lists read, collision first.
        """
        simulation = self._api.simulation
        step, starting_teleports, acceleration = self._calls[:3]
        error = self._client.TraCIException
        on_road = list(vehicles)
        accelerations: dict[str, list[float]] = {vehicle: [] for vehicle in on_road}
        watched: dict[str, float] = {}
        teleported: set[str] = set()
        teleports = 0
        gone: dict[str, PeriodReport] = {}
        for _ in range(steps):
            step()
            if starting_teleports():
                starting = simulation.getStartingTeleportIDList()
                teleports += len(starting)
                teleported.update(starting)
            left = False
            for vehicle in on_road:
                try:
                    accel = acceleration(vehicle)
                except error:
                    collided, arrived = self._why_gone(vehicle)
                    gone[vehicle] = PeriodReport(collided, arrived, vehicle in teleported,
                                                 _lowest(accelerations[vehicle]), teleports,
                                                 simulation.getTime() + self.clock_offset_s,
                                                 tuple(accelerations[vehicle]), watched)
                    left = True
                    continue
                if accel != INVALID_VALUE:  # none while it waits to be inserted
                    accelerations[vehicle].append(accel)
            for vehicle in watch:
                with contextlib.suppress(error):  # a watched vehicle that has left is read no more
                    accel = acceleration(vehicle)
                    if accel != INVALID_VALUE:
                        watched[vehicle] = min(watched.get(vehicle, math.inf), accel)
            if left:
                on_road = [vehicle for vehicle in on_road if vehicle not in gone]
                if not on_road:
                    break
        reports = [gone.get(vehicle) or PeriodReport(False, False, vehicle in teleported,
                                                     _lowest(accelerations[vehicle]), teleports, None,
                                                     tuple(accelerations[vehicle]), watched)
                   for vehicle in vehicles]
        seen_colliding = self.traffic.collided
        if seen_colliding:
            reports = [dataclasses.replace(report, ego_collided=True, ego_left_network=False)
                       if vehicle in seen_colliding and not report.ego_collided else report
                       for vehicle, report in zip(vehicles, reports, strict=True)]
        return reports

    def _why_gone(self, vehicle: str) -> tuple[bool, bool]:
        """(collided, arrived) for an ego SUMO no longer answers about, after a step: collided (and so removed)
        or arrived at the end of its route (the traffic's own record first: an ego that ran into a replayed vehicle may
        answer for the rest of the step and be unknown only at the next, whose collision list no longer names it);
        SimulationError if neither."""
        if vehicle in self.traffic.collided:
            return True, False
        simulation = self._api.simulation
        collided = vehicle in simulation.getCollidingVehiclesIDList()
        if not (collided or vehicle in simulation.getArrivedIDList()):
            raise SimulationError(f"SUMO lost ego {vehicle} without a collision or an arrival")
        return collided, not collided


def _lowest(accelerations_mps2: list[float]) -> float:
    """A period's lowest acceleration [m/s^2] (the first of equals), 0 when none was read."""
    return min(accelerations_mps2, default=0.0)
