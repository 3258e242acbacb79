"""A virtual 360-degree LIDAR: pure numpy ray casting against oriented rectangles and road edges.

Beam i leaves the sensor at angle `heading + i * 360/beams` degrees (counter-clockwise; beam 0 straight
ahead, beam beams/4 to the left, beams/2 behind). Each beam returns the distance [m] to the first thing it
hits (r_max when nothing is within range) and that thing's velocity relative to the ego projected on the
beam [m/s] (positive: moving away; 0 when nothing is hit). Road edges are static, so their relative speed
is minus the ego's velocity along the beam. A sensor origin inside a box reads distance 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_TINY = 1e-12


@dataclass(frozen=True)
class Boxes:
    """Oriented rectangles (vehicles), one row each. Lengths [m], angles [rad, 0 = +x, counter-clockwise]."""

    centre_xy: np.ndarray
    """Shape (M, 2) [m]."""
    heading_rad: np.ndarray
    half_length_m: np.ndarray
    half_width_m: np.ndarray
    velocity_xy: np.ndarray
    """Shape (M, 2) [m/s]."""

    @classmethod
    def from_front(cls, front_xy: np.ndarray, heading_rad: np.ndarray, length_m: np.ndarray, width_m: np.ndarray,
                   speed_mps: np.ndarray) -> Boxes:
        """Boxes from SUMO's front-bumper positions (the centre is half a length behind the front)."""
        direction = np.stack([np.cos(heading_rad), np.sin(heading_rad)], axis=-1).reshape(-1, 2)
        return cls(front_xy - 0.5 * length_m[:, None] * direction, heading_rad, 0.5 * length_m, 0.5 * width_m,
                   speed_mps[:, None] * direction)


def beam_angles(beams: int, heading_rad: float) -> np.ndarray:
    """World angles [rad] of the beams of a sensor facing `heading_rad`."""
    return heading_rad + np.arange(beams) * (2.0 * np.pi / beams)


def scan(origin_xy: np.ndarray, heading_rad: float, velocity_xy: np.ndarray, boxes: Boxes, edges: np.ndarray,
         beams: int, range_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Cast `beams` rays from `origin_xy`; returns (distances [m], relative speeds [m/s]), each shape (beams,).

    `edges` are line segments, shape (S, 2, 2) [m]; `velocity_xy` is the ego's velocity [m/s].
    """
    angles = beam_angles(beams, heading_rad)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    box_distance = _ray_box_distances(origin_xy, directions, boxes)
    edge_distance = _ray_segment_distances(origin_xy, directions, edges)
    distances = np.concatenate([box_distance, edge_distance], axis=1)
    velocities = np.concatenate([boxes.velocity_xy, np.zeros((len(edges), 2))], axis=0)
    if distances.shape[1] == 0:
        return np.full(beams, float(range_m)), np.zeros(beams)
    nearest = np.argmin(distances, axis=1)
    distance = distances[np.arange(beams), nearest]
    relative_speed = np.einsum("bi,bi->b", velocities[nearest] - velocity_xy, directions)
    in_range = distance <= range_m
    return np.where(in_range, distance, float(range_m)), np.where(in_range, relative_speed, 0.0)


def _ray_box_distances(origin: np.ndarray, directions: np.ndarray, boxes: Boxes) -> np.ndarray:
    """Slab test in each box's frame; shape (beams, M), inf where a ray misses."""
    cos_h, sin_h = np.cos(boxes.heading_rad), np.sin(boxes.heading_rad)
    offset = origin - boxes.centre_xy
    local_ox = offset[:, 0] * cos_h + offset[:, 1] * sin_h
    local_oy = -offset[:, 0] * sin_h + offset[:, 1] * cos_h
    ux, uy = directions[:, :1], directions[:, 1:]
    local_ux = _nonzero(ux * cos_h + uy * sin_h)
    local_uy = _nonzero(-ux * sin_h + uy * cos_h)
    tx1 = (-boxes.half_length_m - local_ox) / local_ux
    tx2 = (boxes.half_length_m - local_ox) / local_ux
    ty1 = (-boxes.half_width_m - local_oy) / local_uy
    ty2 = (boxes.half_width_m - local_oy) / local_uy
    t_near = np.maximum(np.minimum(tx1, tx2), np.minimum(ty1, ty2))
    t_far = np.minimum(np.maximum(tx1, tx2), np.maximum(ty1, ty2))
    entry = np.maximum(t_near, 0.0)
    return np.where(t_far >= entry, entry, np.inf)


def _ray_segment_distances(origin: np.ndarray, directions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Ray/segment intersections; shape (beams, S), inf where a ray misses."""
    start = edges[:, 0]
    along = edges[:, 1] - start
    to_start = start - origin
    denominator = _nonzero(directions[:, :1] * along[:, 1] - directions[:, 1:] * along[:, 0])
    t = (to_start[:, 0] * along[:, 1] - to_start[:, 1] * along[:, 0]) / denominator
    s = (to_start[:, 0] * directions[:, 1:] - to_start[:, 1] * directions[:, :1]) / denominator
    return np.where((t >= 0.0) & (s >= 0.0) & (s <= 1.0), t, np.inf)


def _nonzero(values: np.ndarray) -> np.ndarray:
    return np.where(np.abs(values) < _TINY, _TINY, values)
