"""A virtual 360-degree LIDAR: pure numpy ray casting against oriented rectangles and road edges.

Beam i leaves the sensor at angle `heading + i * 360/beams` degrees (counter-clockwise; beam 0 straight
ahead, beam beams/4 to the left, beams/2 behind). Each beam returns the distance [m] to the first thing it
hits (r_max when nothing is within range) and that thing's velocity relative to the ego projected on the
beam [m/s] (positive: moving away; 0 when nothing is hit). Road edges are static zero-width boxes
(`edge_boxes`), so their relative speed is minus the ego's velocity along the beam. A sensor origin
inside a box reads distance 0.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

_TINY = 1e-12


@dataclass(frozen=True)
class Boxes:
    """Oriented rectangles, one row each; every field has shape (M, 2)."""

    centre_xy: np.ndarray
    """Centres [m]."""
    axis_xy: np.ndarray
    """Unit vectors along each box's length (its heading)."""
    half_size_m: np.ndarray
    """Half length and half width [m]."""
    velocity_xy: np.ndarray
    """Velocities [m/s]."""

    @classmethod
    def from_centre(cls, centre_xy: np.ndarray, heading_rad: np.ndarray, length_m: np.ndarray,
                    width_m: np.ndarray, speed_mps: np.ndarray) -> Boxes:
        """Boxes moving along their heading [rad, 0 = +x, counter-clockwise] at `speed_mps`."""
        axis = _unit_vectors(heading_rad)
        return cls(centre_xy, axis, 0.5 * np.stack([length_m, width_m], axis=1), speed_mps[:, None] * axis)

    @classmethod
    def from_front(cls, front_xy: np.ndarray, heading_rad: np.ndarray, length_m: np.ndarray, width_m: np.ndarray,
                   speed_mps: np.ndarray) -> Boxes:
        """Boxes from SUMO's front-bumper positions (the centre is half a length behind the front)."""
        axis = _unit_vectors(heading_rad)
        half_size = 0.5 * np.stack([length_m, width_m], axis=1)
        return cls(front_xy - half_size[:, :1] * axis, axis, half_size, speed_mps[:, None] * axis)


_BOX_FIELDS = tuple(f.name for f in fields(Boxes))


def edge_boxes(segments: np.ndarray) -> Boxes:
    """Static zero-width boxes standing for road-edge segments, shape (S, 2, 2) [m], so one test casts all rays."""
    along = segments[:, 1] - segments[:, 0]
    length = np.hypot(along[:, 0], along[:, 1])
    half_size = np.stack([0.5 * length, np.zeros(len(segments))], axis=1)
    return Boxes(segments.mean(axis=1), along / length[:, None], half_size, np.zeros((len(segments), 2)))


def stack(first: Boxes, second: Boxes) -> Boxes:
    """One set of boxes holding both."""
    return Boxes(*(np.concatenate([getattr(first, name), getattr(second, name)]) for name in _BOX_FIELDS))


def beam_angles(beams: int, heading_rad: float) -> np.ndarray:
    """World angles [rad] of the beams of a sensor facing `heading_rad`."""
    return heading_rad + np.arange(beams) * (2.0 * np.pi / beams)


def scan(origin_xy: np.ndarray, heading_rad: float, velocity_xy: np.ndarray, boxes: Boxes, beams: int,
         range_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Cast `beams` rays from `origin_xy`; returns (distances [m], relative speeds [m/s]), each shape (beams,).

    `boxes` holds vehicles and, via `edge_boxes`, road edges; `velocity_xy` is the ego's velocity [m/s].
    """
    if len(boxes.centre_xy) == 0:
        return np.full(beams, float(range_m)), np.zeros(beams)
    directions = _unit_vectors(beam_angles(beams, heading_rad))
    distance = _ray_box_distances(origin_xy, directions, boxes)
    nearest = distance.argmin(axis=1)
    distance = distance[np.arange(beams), nearest]
    relative_speed = ((boxes.velocity_xy[nearest] - velocity_xy) * directions).sum(axis=1)
    out_of_range = distance > range_m
    distance[out_of_range] = range_m
    relative_speed[out_of_range] = 0.0
    return distance, relative_speed


def _unit_vectors(angles_rad: np.ndarray) -> np.ndarray:
    """(cos, sin) of each angle, shape (N, 2)."""
    vectors = np.empty((len(angles_rad), 2))
    np.cos(angles_rad, out=vectors[:, 0])
    np.sin(angles_rad, out=vectors[:, 1])
    return vectors


def _ray_box_distances(origin: np.ndarray, directions: np.ndarray, boxes: Boxes) -> np.ndarray:
    """Slab test in each box's frame; shape (beams, M), inf where a ray misses.

    Columns [0, M) of the intermediate arrays are the boxes' length axes and [M, 2M) their width axes: numpy
    reduces two contiguous halves much faster than pairs along a last axis of size 2.
    """
    axis = boxes.axis_xy
    m = len(axis)
    frame = np.empty((2 * m, 2))
    frame[:m] = axis
    frame[m:, 0] = -axis[:, 1]
    frame[m:, 1] = axis[:, 0]
    local_origin = (frame.reshape(2, m, 2) * (origin - boxes.centre_xy)).sum(axis=2).reshape(2 * m)
    local_direction = directions @ frame.T  # (beams, 2M)
    local_direction[local_direction == 0.0] = _TINY  # a ray parallel to a side
    inverse = 1.0 / local_direction
    half = boxes.half_size_m.T.reshape(2 * m)
    to_low_side = (-half - local_origin) * inverse
    to_high_side = (half - local_origin) * inverse
    near = np.minimum(to_low_side, to_high_side)
    far = np.maximum(to_low_side, to_high_side)
    entry = np.maximum(near[:, :m], near[:, m:])
    exit_ = np.minimum(far[:, :m], far[:, m:])
    np.maximum(entry, 0.0, out=entry)
    entry[exit_ < entry] = np.inf
    return entry
