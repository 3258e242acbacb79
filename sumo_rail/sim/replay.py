"""A recorded scene's vehicles as a simulation's traffic (`ReplayedTraffic`, a `TrafficSource`), in one of two modes:

- non-reactive (nuPlan's and Waymax's log replay): before every SUMO step each vehicle of the recording is moved
  (`moveToXY`, its recorded lane kept) to where the recording has it at the step's end; it enters when its track
  begins and leaves when it ends, whatever anyone else does. SUMO gives it the speed its move implies, so the ego's
  car following sees the recorded speeds.
- reactive: each vehicle is placed once at its recorded state (position, lane, speed) where its track begins (or at
  the ego's start, when it is on the road then) and from the next step on driven by SUMO's car following and lane
  changing (its type of `VehicleTypes`, else SUMO's default Krauss type; its desired speed the fastest speed its
  track records), so it reacts to the ego; it leaves at the end of the road.

An episode seats the ego (`EGO_ID`) in one recorded vehicle (`ReplayedTraffic.seat`), which is then never placed.
The scene comes in as plain data (`FramesAt`: every vehicle's ids, values and lanes at an instant, interpolated
between frames, so a scene of any frame rate plays at the simulation's step), so this module knows no recording
format. Non-reactive vehicles farther than `REPLAY_RADIUS_M` from the ego along the road are not in SUMO at all: their
recorded path does not depend on anything, and from there they reach neither the ego's perception (LIDAR range +
context margin, 120 m by default) nor its car following (SUMO's leader search reaches its braking distance, 330 m at
44 m/s with the ACC's 3 m/s^2); they enter at their recorded place when they come within it (tests show the same
observations, and a SUMO-driven seat the same speeds, with every vehicle in SUMO).
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
import itertools
import json
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sumo_rail.config import ScenarioConfig
from sumo_rail.datasets import DatasetError, write_bytes_atomically
from sumo_rail.sim import network, scenarios
from sumo_rail.sim.built_network import BuiltNetwork
from sumo_rail.sim.commands import LANE_CHANGE_MODE_SUMO
from sumo_rail.sim.controllers import SUMO_DRIVER_TYPE
from sumo_rail.sim.road import RouteMap
from sumo_rail.sim.simulation import Simulation
from sumo_rail.sim.sumo_api import EGO_ID, SimulationError, decision_calls
from sumo_rail.sim.traffic_source import Step
from sumo_rail.sim.user_network import EGO_CLASS
from sumo_rail.sim.vehicle_types import vtype_element

KEEP_ROUTE_ANY_EDGE = 2
"""moveToXY's keepRoute: place the vehicle on the recorded edge and lane, off its route if need be."""
SPEED_MODE_SUMO = 31
"""SUMO's default speed mode: every safety check on (a released reactive vehicle)."""
REPLAY_RADIUS_M = 500.0
"""Non-reactive vehicles are in SUMO while within this distance of the ego along the road [m]."""
REPLAY_ROUTE = "scene_replay"
"""The first of the routes recorded vehicles are added on (each vehicle's recorded edges from where it enters: one
route for every distinct sequence; the others are this id and a number)."""
FramesAt = Callable[[float], tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]]
"""The scene at an instant [s]: the ids of the vehicles on the road, their values ("x_m", "y_m", "heading_deg",
"speed_mps", "lane_position_m", "length_m", "width_m"; a scene's track columns; "edge", the edge ids) and lanes (SUMO's
index on that edge), one entry each."""
DEFAULT_TYPE = "DEFAULT_VEHTYPE"
"""SUMO's default vehicle type (Krauss, LC2013): a vehicle's without one of `VehicleTypes`."""


@dataclass(frozen=True)
class VehicleTypes:
    """SUMO vehicle types of a scene's simulation: `definitions` (type id -> vType attributes and children as
    `vehicle_types` keeps them, written into its routes file) and `of_vehicle` (recorded vehicle -> type id: how it
    drives in the reactive mode; SUMO's default type for the others and for every replayed vehicle of the non-reactive
    mode, which SUMO does not drive)."""

    definitions: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    of_vehicle: Mapping[str, str] = field(default_factory=dict)

    @property
    def key(self) -> str:
        """A digest of the types (equal types, equal keys): what tells simulations of other types apart."""
        content = json.dumps([self.definitions, self.of_vehicle], sort_keys=True).encode()
        return hashlib.sha256(content).hexdigest()[:16]


NO_TYPES = VehicleTypes()
"""No vehicle type but SUMO's own (every reactive vehicle SUMO's default Krauss)."""


class ReplayedTraffic:
    """The vehicles of a scene on its network: `frames_at` the scene at any instant, `begins_s` each track's first
    time [s] (sorted: the reactive mode looks for vehicles to place only when one begins), `top_speeds_mps` each
    vehicle's fastest recorded speed [m/s] (its desired speed in the reactive mode), `routes` each vehicle's recorded
    edges in order (junctions left out: the route it is added on, and the seated ego's from its edge on),
    `classes` each vehicle's SUMO vehicle class (the seated ego's; none given: a passenger car's); `reactive`
    chooses the mode, `types` the vehicle types SUMO knows (the reactive vehicles' and a SUMO-driven ego's)."""

    def __init__(self, frames_at: FramesAt, begins_s: np.ndarray, top_speeds_mps: Mapping[str, float],
                 routes: Mapping[str, tuple[str, ...]], reactive: bool, classes: Mapping[str, str] | None = None,
                 types: VehicleTypes = NO_TYPES) -> None:
        self.frames_at = frames_at
        self.routes = routes
        self.classes = classes or {}
        distinct = sorted({route[start:] for route in set(routes.values()) for start in range(len(route))})
        self._route_ids = {route: REPLAY_ROUTE if not k else f"{REPLAY_ROUTE}_{k}" for k, route in enumerate(distinct)}
        self._route_maps: dict[tuple[str, ...], RouteMap] = {}
        """The seated ego's route frame by its route (`seat`)."""
        self.reactive = reactive
        self.types = types
        self._begins_s = np.asarray(begins_s)
        self._top_speeds_mps = top_speeds_mps
        self._speed_factor: dict[str, float] = {}
        """Each vehicle's desired speed in the reactive mode, as a share of the road's limit."""
        self.api: Any = None
        """The SUMO connection (`connect`)."""
        self._calls: Any = None
        """Its calls of every step (`connect`; libsumo's compiled ones: `sumo_api.decision_calls`)."""
        self._step_s = 0.0
        self.ego_collisions: list[tuple[str, str]] = []
        """(collider, victim) of each collision of the ego in the episode (SUMO's collider: the follower)."""
        self.seated: tuple[str, float] = ("", 0.0)
        """The recorded vehicle whose seat the ego took and when [s]."""
        self._ego_in = False
        """The ego is on the road (seated, not yet gone)."""
        self._skip = ""
        """The seat's vehicle, never placed."""
        self._placed: set[str] = set()
        """Vehicles placed so far (reactive: they are SUMO's from the step after)."""
        self._releasing: list[str] = []
        self._last_s = -np.inf
        self._clock_offset_s = 0.0
        """The scene's time less SUMO's clock [s] (`Simulation.clock_offset_s`)."""

    def network(self, scenario: ScenarioConfig) -> BuiltNetwork:
        """The scene's road with its routes file less the generated flows, with the replay's route, the type of
        SUMO's own driver in the seat (`SUMO_DRIVER_TYPE`) and `types`' definitions (replacing the road's own types of
        the same ids; the file named by its content: simulations of other types share the road's folder)."""
        built = network.build(scenario)
        root = ElementTree.parse(built.routes_file).getroot()
        for flow in root.findall("flow"):
            root.remove(flow)
        # the road's own traffic's types (its flows are gone) give way to the scene's; the ego's never do
        scenarios.drop_types(root, set(self.types.definitions) - {network.EGO_TYPE, network.ACCELERATION_EGO_TYPE})
        for route, route_id in self._route_ids.items():
            ElementTree.SubElement(root, "route", id=route_id, edges=" ".join(route))
        ElementTree.SubElement(root, "vType", id=SUMO_DRIVER_TYPE, carFollowModel="IDM", laneChangeModel="LC2013")
        for type_id, definition in self.types.definitions.items():
            vtype_element(root, type_id, definition)
        content = ElementTree.tostring(root)
        routes = built.directory / f"scene.{hashlib.sha256(content).hexdigest()[:16]}.rou.xml"
        write_bytes_atomically(routes, content)
        return dataclasses.replace(built, routes_file=routes)

    def connect(self, api: Any, step_s: float, speed_limit_mps: float) -> Step:
        self.api, self._step_s, self._calls = api, step_s, decision_calls(api)
        self._speed_factor = {str(name): float(top / speed_limit_mps) for name, top in self._top_speeds_mps.items()}
        return self.step

    @property
    def collided(self) -> Collection[str]:
        return (EGO_ID,) if self.ego_collisions else ()

    def check_warm_start(self) -> None:
        raise SimulationError("a scene's episodes start in a recorded vehicle's seat (seat), not from warm states")

    def seat(self, sim: Simulation, vehicle: str, start_s: float, sumo_seed: int) -> None:
        """Load `sim`'s road afresh at `start_s` [s] with SUMO seed `sumo_seed`, place the recorded vehicles there (but
        `vehicle`) and put the ego in `vehicle`'s place, state, size and class; DatasetError when it is not on the road
        then."""
        sim.load_empty(start_s - self._step_s, sumo_seed)
        self._clock_offset_s = sim.clock_offset_s
        self.ego_collisions.clear()
        self._ego_in = False
        self.seated = (vehicle, start_s)
        self._skip = vehicle
        self._placed.clear()
        self._releasing.clear()
        self._last_s = -np.inf
        sim.advance(1)
        ids, values, lanes = self.frames_at(start_s)
        row = np.flatnonzero(ids == vehicle)
        if not len(row):
            raise DatasetError(f"vehicle {vehicle} of the scene is not on the road at {start_s:g} s")
        k, vehicle_api = int(row[0]), self.api.vehicle
        speed_mps = float(values["speed_mps"][k])
        edge = str(values["edge"][k])
        route = self._ego_route(sim, vehicle, edge, int(lanes[k]))
        # placed standing, then given the recorded speed: SUMO refuses a departure above the type's limit on the lane
        sim.put_ego(EGO_ID, int(lanes[k]), float(values["lane_position_m"][k]), 0.0, route,
                    "" if edge == route[0] else edge)
        vehicle_api.setSpeedFactor(EGO_ID, max(1.0, speed_mps / sim.speed_limit_mps))
        vehicle_api.setPreviousSpeed(EGO_ID, speed_mps)
        sim.resize(EGO_ID, float(values["length_m"][k]), float(values["width_m"][k]))
        vehicle_class = self.classes.get(vehicle, EGO_CLASS)
        if vehicle_class != EGO_CLASS:  # the ego's type is a passenger car's
            vehicle_api.setVehicleClass(EGO_ID, vehicle_class)
        self._ego_in = True

    def _ego_route(self, sim: Simulation, vehicle: str, edge: str, lane: int) -> tuple[str, ...]:
        """The seated ego's route: `vehicle`'s recorded edges from `edge` (where it is, in `lane`) on, or in a
        junction from the edge before it; `sim`'s route frame made that route's (the network's own when it is the
        simulation's route)."""
        recorded = self.routes[vehicle]
        if edge not in recorded:  # a junction's lane: its link leads to the next edge
            links = self.api.lane.getLinks(f"{edge}_{lane}")
            after = self.api.lane.getEdgeID(links[0][0]) if links else ""
            if after not in recorded[1:]:
                raise DatasetError(f"vehicle {vehicle} of the scene is in junction lane {edge}_{lane} at its seat's "
                                   f"instant, which leads to no edge of its recorded route")
            edge = recorded[recorded.index(after) - 1]
        route = recorded[recorded.index(edge):]
        maps = self._route_maps
        if not maps:
            maps[sim.route_map.route] = sim.route_map
        if route not in maps:
            maps[route] = RouteMap.from_sumo(self.api, route, sim.scenario.lanes)
        sim.route_map = maps[route]
        return route

    def step(self) -> None:
        """One SUMO step with the recorded vehicles placed for its end; the ego's collisions kept."""
        calls = self._calls
        end_s = calls.time_s() + self._step_s  # SUMO's clock; the scene's is `_clock_offset_s` later
        self._place(end_s + self._clock_offset_s, calls.position(EGO_ID)[0] if self._ego_in and not self.reactive
                    else None)
        calls.step(end_s)  # to a time: over traci a plain step after a load may keep SUMO's clock
        simulation = self.api.simulation
        if simulation.getCollidingVehiclesNumber():
            self.ego_collisions += [(collision.collider, collision.victim) for collision in simulation.getCollisions()
                                    if EGO_ID in (collision.collider, collision.victim)]
            self._ego_in = self._ego_in and not self.ego_collisions
        if self._ego_in and simulation.getArrivedNumber() and EGO_ID in simulation.getArrivedIDList():
            self._ego_in = False

    def _place(self, time_s: float, ego_x_m: float | None) -> None:
        """Put the recorded vehicles where the recording has them at `time_s` [s]; called before the SUMO step that
        ends at `time_s`. `ego_x_m`: the ego's x [m] (None before it is on the road: the recorded x of its seat; the
        reactive mode places every vehicle, wherever the ego is)."""
        if self.reactive:
            self._release()
            begun = np.searchsorted(self._begins_s, [self._last_s, time_s], side="right")
            first, self._last_s = not self._placed, time_s
            if not first and begun[0] == begun[1]:
                return  # no track begins in this step: nothing to place
        ids, values, lanes = self.frames_at(time_s)
        placing = ids != self._skip  # the seat's vehicle is never placed
        if not self.reactive:
            x = values["x_m"]
            if ego_x_m is None:
                seat = (~placing).nonzero()[0]
                ego_x_m = float(x[seat[0]]) if len(seat) else None
            if ego_x_m is not None:
                placing &= np.abs(x - ego_x_m) <= REPLAY_RADIUS_M
        rows = placing.nonzero()[0]
        names = ids[rows].tolist()
        vehicle = self.api.vehicle
        on_road = set(self._calls.vehicle_ids())
        if not self.reactive:
            gone = self._placed.difference(names)
            watched = vehicle.getAllSubscriptionResults() if gone else {}
            for name in gone:
                if name in on_road:
                    if name in watched:  # an observer's subscription (`observers.VehicleRows`) goes with it
                        vehicle.unsubscribe(name)
                    vehicle.remove(name)
            self._placed -= gone
        moves = (names, values["edge"][rows].tolist(), lanes[rows].tolist(),
                 *(values[name][rows].tolist() for name in ("x_m", "y_m", "heading_deg")))
        if self.reactive or not on_road.issuperset(names):
            self._add(moves, [values[name][rows].tolist() for name in ("speed_mps", "length_m", "width_m")], on_road)
        else:  # every vehicle is SUMO's already (most steps): only moves, looped in C
            collections.deque(itertools.starmap(self._calls.move_to_xy,
                                                zip(*moves, itertools.repeat(KEEP_ROUTE_ANY_EDGE), strict=False)),
                              maxlen=0)

    def _add(self, moves: tuple[list[Any], ...], sizes: list[list[float]], on_road: set[str]) -> None:
        """`_place`'s vehicles (`moves`: ids, edges, lanes, x [m], y [m], headings [deg]; `sizes`: speeds [m/s],
        lengths and widths [m]), added to SUMO where they are not on the road (`on_road`), each before its move (the
        reactive mode moves only those it adds)."""
        calls, placed = self._calls, self._placed
        type_of = self.types.of_vehicle if self.reactive else {}
        for name, edge, lane, x_m, y_m, heading_deg, speed_mps, length_m, width_m in zip(*moves, *sizes, strict=True):
            if self.reactive and name in placed:
                continue
            if name not in on_road:  # new, or (non-reactive) removed by SUMO after a collision: placed again
                route_id, depart_lane = self._entry(name, edge, lane)
                calls.add(name, route_id, type_of.get(name, DEFAULT_TYPE), "now", depart_lane, "base", repr(speed_mps))
                calls.set_length(name, length_m)
                calls.set_width(name, width_m)
                calls.set_speed_mode(name, 0)
                calls.set_lane_change_mode(name, 0)
                placed.add(name)
                if self.reactive:
                    self._releasing.append(name)
            elif self.reactive:
                continue
            calls.move_to_xy(name, edge, lane, x_m, y_m, heading_deg, KEEP_ROUTE_ANY_EDGE)

    def _entry(self, vehicle: str, edge: str, lane: int) -> tuple[str, str]:
        """The route `vehicle` is added on where it is, in lane `lane` of `edge`: its recorded edges from `edge` on
        (in a junction: all of them), and its depart lane (SUMO's best in a junction; `moveToXY` places it)."""
        route = self.routes[vehicle]
        if edge in route:
            return self._route_ids[route[route.index(edge):]], str(lane)
        return self._route_ids[route], "best"

    def _release(self) -> None:
        """Hand the vehicles placed before the last step to SUMO's models (reactive mode)."""
        calls = self._calls
        on_road = set(calls.vehicle_ids()) if self._releasing else set()
        for name in self._releasing:
            if name in on_road:
                calls.set_speed_mode(name, SPEED_MODE_SUMO)
                calls.set_lane_change_mode(name, LANE_CHANGE_MODE_SUMO)
                self.api.vehicle.setSpeedFactor(name, self._speed_factor[name])
        self._releasing.clear()
