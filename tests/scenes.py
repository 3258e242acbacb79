"""Hand-made traffic views for tests of drivers and of what is measured on them (importable: tests/ is on the path)."""

import libsumo
import numpy as np

from sumo_rail.sim.observers import Moment
from sumo_rail.sim.simulation import EgoState, Neighbours
from sumo_rail.sim.traffic import TrafficView

EGO_FRONT = 1000.0


def view(others=(), lane=1, speed=25.0, set_point=25.0, lateral=0.0, lanes=5):
    """others: (lane, front position [m], length [m], speed [m/s]) of each neighbour."""
    ego = EgoState(front_x=EGO_FRONT, front_y=0.0, heading_rad=0.0, speed_mps=speed, lane=lane,
                   lane_position_m=EGO_FRONT, lateral_offset_m=lateral, length_m=4.5, width_m=1.8)
    rows = np.array(others, dtype=float).reshape(-1, 4)
    count = len(rows)
    neighbours = Neighbours(ids=tuple(f"v{i}" for i in range(count)), front_xy=np.zeros((count, 2)),
                            heading_rad=np.zeros(count), speed_mps=rows[:, 3], lane_position_m=rows[:, 1],
                            length_m=rows[:, 2], width_m=np.full(count, 1.8), lane=rows[:, 0].astype(int))
    return TrafficView(ego, neighbours, set_point, lanes)


def decided(traffic, action, info, observation=None):
    """The decision moment of one ego that chose `action` in `traffic` (and `observation`), the step's `info` (what
    an observer of decisions is shown, `sumo_rail.sim.observers.Moment`)."""
    seen = np.zeros(0) if observation is None else observation
    return Moment(0.0, "decision", dict, {"ego": int(action)}, {"ego": info}, {"ego": (seen, traffic)})


def two_vehicle_road(env, other, other_lane, ego_speed, other_speed):
    """Reset `env` (seed 0), leave only the ego and a car `other` in `other_lane` on the road, both held by SUMO at
    exactly the given speeds [m/s] (no safety checks; `other` changes no lanes) after one decision; returns the
    edge both are on, for `libsumo.vehicle.moveTo`."""
    env.reset(seed=0)
    for vehicle in libsumo.vehicle.getIDList():
        if vehicle != "ego":
            libsumo.vehicle.remove(vehicle)
    route, edge = libsumo.vehicle.getRouteID("ego"), libsumo.vehicle.getRoadID("ego")
    libsumo.vehicle.add(other, route, typeID="car", depart="now", departLane=str(other_lane), departPos="300",
                        departSpeed=repr(other_speed))
    for vehicle, speed in (("ego", ego_speed), (other, other_speed)):
        libsumo.vehicle.setSpeedMode(vehicle, 0)
        libsumo.vehicle.setSpeed(vehicle, speed)
    libsumo.vehicle.setLaneChangeMode(other, 0)
    env.step(0)  # both at their speeds
    return edge
