"""Watching a simulation: the one way the project captures what happens in an episode. An observer is called after
every SUMO step (`every_step`: `Simulation.watching`, e.g. a recording of SUMO's own drivers) or after each reset and
each decision of the egos (`ParallelHighwayEnv.watching`, e.g. a video's frames, the expert check's capture, an
evaluation's measures) with a `Moment`: the time, at a decision each ego's `Decision` (what it decided on, its action,
the step's info), and every vehicle on the road as track rows, read from SUMO only when an observer asks
(`VehicleRows`). `VehicleCapture` keeps those rows moment after moment.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, Protocol, TypeVar

if TYPE_CHECKING:
    import numpy as np

    from sumo_rail.sim.traffic import TrafficView

ROW_FIELDS = ("vehicle_id", "x_m", "y_m", "heading_deg", "speed_mps", "acceleration_mps2", "edge", "lane",
              "lane_position_m", "length_m", "width_m", "vehicle_class", "type")
"""A vehicle's row (a scene's track columns, `sumo_rail.recordings.scene`, but the time, and its SUMO vehicle type):
its front bumper's centre [m], SUMO's angle [deg], speed [m/s], acceleration [m/s^2], edge, lane index on it, position
along the lane [m], length and width [m], class ("truck" for SUMO's trucks, else "passenger") and vType."""
Rows = dict[str, list[Any]]
"""Columns of `ROW_FIELDS`, one entry per vehicle."""


class VehicleRows:
    """Every vehicle on the road of a SUMO connection `api` (with TraCI's `constants`) as rows: one variable
    subscription per vehicle, made when it is first seen (SUMO answers it at once and drops it when the vehicle
    leaves); its size, class and type read once. Good for one load of the simulation (ids start again after one)."""

    def __init__(self, api: Any, constants: Any) -> None:
        self.api = api
        c = constants
        self.variables = (c.VAR_POSITION, c.VAR_ANGLE, c.VAR_SPEED, c.VAR_ACCELERATION, c.VAR_ROAD_ID,
                          c.VAR_LANE_INDEX, c.VAR_LANEPOSITION)
        self._seen: set[str] = set()
        self._kinds: dict[str, tuple[float, float, str, str]] = {}

    def read(self) -> Rows:
        """The rows of every vehicle on the road now, in the order SUMO gives the subscriptions' results."""
        vehicle = self.api.vehicle
        ids = vehicle.getIDList()
        for name in ids:
            if name not in self._seen:
                vehicle.subscribe(name, self.variables)
        self._seen = set(ids)
        rows: Rows = {name: [] for name in ROW_FIELDS}
        position, angle, speed, acceleration, road, lane, lane_position = self.variables
        for name, values in vehicle.getAllSubscriptionResults().items():
            kind = self._kinds.get(name) or self._kind(name)
            x, y = values[position]
            for column, value in zip(ROW_FIELDS, (name, x, y, values[angle], values[speed], values[acceleration],
                                                   values[road], values[lane], values[lane_position], *kind),
                                     strict=True):
                rows[column].append(value)
        return rows

    def _kind(self, name: str) -> tuple[float, float, str, str]:
        vehicle = self.api.vehicle
        kind = self._kinds[name] = (vehicle.getLength(name), vehicle.getWidth(name),
                                    "truck" if vehicle.getVehicleClass(name) == "truck" else "passenger",
                                    vehicle.getTypeID(name))
        return kind


class Decision(NamedTuple):
    """One ego's decision: what it decided on (its observation and its traffic view, read from SUMO), the action its
    car executed and the step's info."""

    agent: str
    observation: np.ndarray
    traffic: TrafficView
    action: int
    info: dict[str, Any]


@dataclass
class Moment:
    """What an observer is shown: the simulation time [s], what happened ("reset": the egos' episode began, "decision":
    the egos decided and SUMO ran the period, "step": one SUMO step), at a decision each ego's executed action, the
    step's info and what it decided on (`decisions()`; at a reset each ego's first info), and `vehicles()`."""

    time_s: float
    kind: Literal["reset", "decision", "step"]
    read: Callable[[], Rows] = field(repr=False)
    actions: Mapping[str, int] = field(default_factory=dict)
    infos: Mapping[str, dict[str, Any]] = field(default_factory=dict)
    seen: Mapping[str, tuple[np.ndarray, TrafficView]] = field(default_factory=dict)
    """At a decision, what each ego decided on: its observation and traffic view before the period."""
    _rows: Rows | None = field(default=None, init=False, repr=False)

    def decisions(self) -> list[Decision]:
        """Each ego's decision, in the egos' order (none at a reset or a step)."""
        return [Decision(agent, *self.seen[agent], action, self.infos[agent]) for agent, action in self.actions.items()]

    def vehicles(self) -> Rows:
        """Every vehicle on the road now (`ROW_FIELDS`), read from SUMO once per moment."""
        if self._rows is None:
            self._rows = self.read()
        return self._rows


class Observer(Protocol):
    """Watches episodes; it only reads (what it is shown cannot change what happens)."""

    every_step: bool
    """Called after every SUMO step (True), or after each reset and decision of the egos (False)."""

    def __call__(self, moment: Moment) -> None: ...


WatchedObserver = TypeVar("WatchedObserver", bound=Observer)
"""An observer's own type, as `watching` hands it back."""


@dataclass
class VehicleCapture:
    """Every vehicle at every moment it is shown, as columns (`ROW_FIELDS`, "time_s" and "frame", the moment's index
    from 0)."""

    every_step: bool
    columns: Rows = field(default_factory=lambda: {name: [] for name in ("frame", "time_s", *ROW_FIELDS)})
    moments: int = 0

    def __call__(self, moment: Moment) -> None:
        rows = moment.vehicles()
        count = len(rows["vehicle_id"])
        self.columns["frame"] += [self.moments] * count
        self.columns["time_s"] += [moment.time_s] * count
        for name in ROW_FIELDS:
            self.columns[name] += rows[name]
        self.moments += 1
