"""A virtual 360-degree LIDAR: pure numpy ray casting against oriented rectangles and road edges.

Beam i leaves the sensor at angle `heading + i * 360/beams` degrees (counter-clockwise; beam 0 straight
ahead, beam beams/4 to the left, beams/2 behind). Each beam returns the distance [m] to the first thing it
hits (r_max when nothing is within range) and that thing's velocity relative to the ego projected on the
beam [m/s] (positive: moving away; 0 when nothing is hit). Road edges are static zero-width boxes
(`edge_boxes`), so their relative speed is minus the ego's velocity along the beam. A sensor origin
inside a box reads distance 0.
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
        direction = np.empty((len(heading_rad), 2))
        np.cos(heading_rad, out=direction[:, 0])
        np.sin(heading_rad, out=direction[:, 1])
        return cls(front_xy - (0.5 * length_m)[:, None] * direction, heading_rad, 0.5 * length_m, 0.5 * width_m,
                   speed_mps[:, None] * direction)


def edge_boxes(segments: np.ndarray) -> Boxes:
    """Static zero-width boxes standing for road-edge segments, shape (S, 2, 2) [m], so one test casts all rays."""
    along = segments[:, 1] - segments[:, 0]
    return Boxes(segments.mean(axis=1), np.arctan2(along[:, 1], along[:, 0]), 0.5 * np.hypot(*along.T),
                 np.zeros(len(segments)), np.zeros((len(segments), 2)))


def stack(first: Boxes, second: Boxes) -> Boxes:
    """One set of boxes holding both."""
    return Boxes(*(np.concatenate([getattr(first, f), getattr(second, f)]) for f in Boxes.__dataclass_fields__))


def beam_angles(beams: int, heading_rad: float) -> np.ndarray:
    """World angles [rad] of the beams of a sensor facing `heading_rad`."""
    return heading_rad + np.arange(beams) * (2.0 * np.pi / beams)


def scan(origin_xy: np.ndarray, heading_rad: float, velocity_xy: np.ndarray, boxes: Boxes, beams: int,
         range_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Cast `beams` rays from `origin_xy`; returns (distances [m], relative speeds [m/s]), each shape (beams,).

    `boxes` holds vehicles and, via `edge_boxes`, road edges; `velocity_xy` is the ego's velocity [m/s].
    """
    if len(boxes.half_length_m) == 0:
        return np.full(beams, float(range_m)), np.zeros(beams)
    angles = beam_angles(beams, heading_rad)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    distances = _ray_box_distances(origin_xy, directions, boxes)
    nearest = np.argmin(distances, axis=1)
    distance = distances[np.arange(beams), nearest]
    relative_speed = np.einsum("bi,bi->b", boxes.velocity_xy[nearest] - velocity_xy, directions)
    in_range = distance <= range_m
    return np.where(in_range, distance, float(range_m)), np.where(in_range, relative_speed, 0.0)


def _ray_box_distances(origin: np.ndarray, directions: np.ndarray, boxes: Boxes) -> np.ndarray:
    """Slab test in each box's frame; shape (beams, M), inf where a ray misses."""
    cos_h, sin_h = np.cos(boxes.heading_rad), np.sin(boxes.heading_rad)
    offset = origin - boxes.centre_xy
    local_ox = offset[:, 0] * cos_h + offset[:, 1] * sin_h
    local_oy = offset[:, 1] * cos_h - offset[:, 0] * sin_h
    ux, uy = directions[:, :1], directions[:, 1:]
    inverse_ux = 1.0 / _nonzero(ux * cos_h + uy * sin_h)
    inverse_uy = 1.0 / _nonzero(uy * cos_h - ux * sin_h)
    tx1 = (-boxes.half_length_m - local_ox) * inverse_ux
    tx2 = (boxes.half_length_m - local_ox) * inverse_ux
    ty1 = (-boxes.half_width_m - local_oy) * inverse_uy
    ty2 = (boxes.half_width_m - local_oy) * inverse_uy
    entry = np.maximum(np.maximum(np.minimum(tx1, tx2), np.minimum(ty1, ty2)), 0.0)
    t_far = np.minimum(np.maximum(tx1, tx2), np.maximum(ty1, ty2))
    return np.where(t_far >= entry, entry, np.inf)


def _nonzero(values: np.ndarray) -> np.ndarray:
    """`values` with exact zeros (rays parallel to a box side) replaced by a tiny number, in place."""
    values[values == 0.0] = _TINY
    return values
