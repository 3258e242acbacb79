"""`EgoFrames`: bird's-eye frames of one road's egos, each of an ego's last decision (the env core's `frame`)."""

from __future__ import annotations

import math

import numpy as np

from sumo_rail.config import Config
from sumo_rail.sim.ego import Ego
from sumo_rail.sim.map_render import MapRenderer
from sumo_rail.sim.render import FrameRenderer, FrameText
from sumo_rail.sim.simulation import Simulation


class EgoFrames:
    """Frames of the egos of one env: the road's drawing (a straight edge, or a map of the lanes' shapes) is made
    once, at the first frame."""

    def __init__(self, config: Config) -> None:
        self.config = config
        self._renderer: FrameRenderer | None = None

    def draw(self, sim: Simulation, ego: Ego) -> np.ndarray:
        """RGB frame (H, W, 3) uint8 of `ego`'s last decision: the road, every vehicle in LIDAR range coloured by
        type, the ego, its LIDAR beams and hits, and its speed, set-point, lane and last action."""
        cfg, traffic = self.config, ego.traffic
        if traffic is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            self._renderer = (FrameRenderer(sim.road_edges(), cfg.scenario.lanes) if sim.route_map.single_edge
                              else MapRenderer(sim.lane_shapes(), cfg.scenario.lanes))
        # the observation holds distance / r_max, clipped to 1: exactly what the policy saw
        distances = ego.last_observation[:cfg.lidar.beams].astype(np.float64) * cfg.lidar.range_m
        set_point_mps = math.nan if ego.accelerating else traffic.set_point_mps  # the interface has none
        text = FrameText(sim.time_s, traffic.ego.speed_mps, set_point_mps, traffic.ego.lane,
                         cfg.scenario.lanes, ego.action_label(),
                         ego.metrics.decisions)
        return self._renderer.draw(traffic.ego, traffic.neighbours, sim.vehicle_types(traffic.neighbours.ids),
                                   distances, cfg.lidar.range_m, text)
