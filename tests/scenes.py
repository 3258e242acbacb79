"""Hand-made traffic views for tests of drivers and of what is measured on them (importable: tests/ is on the path)."""

import numpy as np

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
