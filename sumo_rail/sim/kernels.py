"""Compiled (numba) kernel of the per-decision numeric work: the LIDAR scan and the observation, in one call.

`lidar.scan` + `observation.build_observation` (numpy) stay the reference: this kernel repeats their arithmetic
operation for operation, in the same order, so on the machines it was checked on it gives the same float32 bits
(tests compare them on random scenes). Numpy's matrix product fuses the second multiply-add of each
direction-to-box-frame projection (OpenBLAS's FMA kernels), so the kernel does the same with an explicit fused
multiply-add. Compiled code is cached on disk (`__pycache__` beside this file, else numba's user-wide cache); where
neither is writable it is compiled once per process instead.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

log = logging.getLogger(__name__)

_TINY = 1e-12
"""Stands for a zero direction component, as in `lidar._ray_box_distances`."""
_CULL_MARGIN_M = 1.0
"""Boxes farther than the LIDAR range plus this [m] are left out of the scan (`_keep_near`): far more than the
rounding of the slab arithmetic, so that such a box's entry distance is beyond range however it rounds."""


def jit(function: Callable[..., Any]) -> Any:
    """`numba.njit` with an on-disk cache, or without one where no cache location is writable."""
    try:
        return numba.njit(cache=True)(function)
    except RuntimeError as error:  # numba finds no writable cache directory for this file
        log.info("numba cannot cache %s (%s); compiling it in this process", function.__qualname__, error)
        return numba.njit(function)


@intrinsic
def _fma(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """a * b + c with a single rounding (LLVM's fma)."""
    signature = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, sig: Any, args: Any) -> Any:
        return builder.fma(*args)

    return signature, codegen


@jit
def _slab_entry(o_len: float, o_wid: float, d_len: float, d_wid: float, half_len: float, half_wid: float) -> float:
    """Entry distance of a ray into a box given in the box's frame [m]; inf when it misses."""
    if d_len == 0.0:
        d_len = _TINY
    if d_wid == 0.0:
        d_wid = _TINY
    inv_len, inv_wid = 1.0 / d_len, 1.0 / d_wid
    low_len, high_len = (-half_len - o_len) * inv_len, (half_len - o_len) * inv_len
    low_wid, high_wid = (-half_wid - o_wid) * inv_wid, (half_wid - o_wid) * inv_wid
    near_len, far_len = min(low_len, high_len), max(low_len, high_len)
    near_wid, far_wid = min(low_wid, high_wid), max(low_wid, high_wid)
    entry = max(max(near_len, near_wid), 0.0)
    return np.inf if min(far_len, far_wid) < entry else entry


@jit
def _keep_near(frame: np.ndarray, count: int, o_len: float, o_wid: float, axis_x: float, axis_y: float,
               half_len: float, half_wid: float, velocity_x: float, velocity_y: float, range_m: float) -> int:
    """Store a box's row (`_lidar`'s frame) at `count` unless the box is beyond `range_m` + `_CULL_MARGIN_M` along
    one of its axes from the ray origin (`o_len`, `o_wid` [m], in its frame); returns the rows stored.

    A ray enters such a box only past `range_m`, where `_lidar` reads nothing, so leaving it out changes no beam:
    the nearest box within range, the first of equals, is the same among the boxes kept, in the same order. Most of
    the road-edge boxes of a network lie far from the ego, and each one left out saves a slab test per beam."""
    if max(abs(o_len) - half_len, abs(o_wid) - half_wid) > range_m + _CULL_MARGIN_M:
        return count
    frame[count] = (o_len, o_wid, axis_x, axis_y, half_len, half_wid, velocity_x, velocity_y)
    return count + 1


@jit
def _lidar(front_xy: np.ndarray, heading_rad: np.ndarray, length_m: np.ndarray, width_m: np.ndarray,
           speed_mps: np.ndarray, edges: np.ndarray, front_x: float, front_y: float, heading: float, ego_length: float,
           ego_speed: float, beams: int, range_m: float, v_max_mps: float, observation: np.ndarray) -> None:
    """Write the LIDAR part of the observation, [0, 2 * beams): each beam's distance / `range_m` and the relative
    speed along it / `v_max_mps` [-]; neighbours and road edges as in `observation_vector`, the ego's front [m],
    heading [rad], length [m] and speed [m/s]."""
    cos_h, sin_h = math.cos(heading), math.sin(heading)
    half = 0.5 * ego_length
    origin_x, origin_y = front_x - half * cos_h, front_y - half * sin_h
    ego_vx, ego_vy = ego_speed * cos_h, ego_speed * sin_h
    # per box within reach: origin in the box frame (length, width), axis x, y, half length, half width, velocity x, y
    frame = np.empty((len(heading_rad) + len(edges), 8))
    boxes = 0
    for j in range(len(heading_rad)):
        axis_x, axis_y = math.cos(heading_rad[j]), math.sin(heading_rad[j])
        half_len = 0.5 * length_m[j]
        dx, dy = origin_x - (front_xy[j, 0] - half_len * axis_x), origin_y - (front_xy[j, 1] - half_len * axis_y)
        boxes = _keep_near(frame, boxes, axis_x * dx + axis_y * dy, -axis_y * dx + axis_x * dy, axis_x, axis_y,
                           half_len, 0.5 * width_m[j], speed_mps[j] * axis_x, speed_mps[j] * axis_y, range_m)
    for k in range(len(edges)):
        axis_x, axis_y = edges[k, 2], edges[k, 3]
        dx, dy = origin_x - edges[k, 0], origin_y - edges[k, 1]
        boxes = _keep_near(frame, boxes, axis_x * dx + axis_y * dy, -axis_y * dx + axis_x * dy, axis_x, axis_y,
                           edges[k, 4], edges[k, 5], 0.0, 0.0, range_m)
    step = 2.0 * np.pi / beams
    inverse_range, inverse_v_max = 1.0 / range_m, 1.0 / v_max_mps
    for i in range(beams):
        angle = heading + i * step
        ray_x, ray_y = math.cos(angle), math.sin(angle)
        distance, relative_speed = range_m, 0.0
        if boxes:
            nearest, best = 0, np.inf
            for j in range(boxes):
                axis_x, axis_y = frame[j, 2], frame[j, 3]
                entry = _slab_entry(frame[j, 0], frame[j, 1],
                                    _fma(ray_y, axis_y, ray_x * axis_x),  # type: ignore[call-arg]  # numba intrinsic
                                    _fma(ray_y, axis_x, ray_x * -axis_y),  # type: ignore[call-arg]  # numba intrinsic
                                    frame[j, 4], frame[j, 5])
                if entry < best:
                    nearest, best = j, entry
            if not best > range_m:
                distance = best
                relative_speed = (frame[nearest, 6] - ego_vx) * ray_x + (frame[nearest, 7] - ego_vy) * ray_y
        observation[i] = min(distance * inverse_range, 1.0)
        observation[beams + i] = min(max(relative_speed * inverse_v_max, -1.0), 1.0)


@jit
def _lane_block(lane_position_m: np.ndarray, length_m: np.ndarray, lane: np.ndarray, speed_mps: np.ndarray,
                ego_position: float, ego_length: float, ego_speed: float, ego_lane: int, lanes: int, range_m: float,
                v_max_mps: float, observation: np.ndarray, start: int) -> None:
    """Write the lane block (`traffic.lane_block`, its reference, operation for operation) at `start`: for the lanes
    right of, at and left of the ego (route lanes), the gap to the nearest vehicle ahead / `range_m` and its speed
    relative to the ego's / `v_max_mps`, then the same behind; the neighbours' fronts along the route [m], lengths
    [m], route lanes and speeds [m/s]; the ego's front along the route [m], length [m], speed [m/s] and route lane."""
    ego_rear = ego_position - ego_length
    lowest = ego_lane - 1
    nearest_rear = np.full(3, np.inf)  # per lane (right, own, left): the rear of the nearest vehicle ahead [m] ...
    front_speed = np.full(3, np.inf)
    nearest_front = np.full(3, -np.inf)  # ... and the front of the nearest one behind [m]
    rear_speed = np.full(3, np.inf)
    for j in range(len(lane)):
        row = lane[j] - lowest
        if not 0 <= row < 3:
            continue
        front = lane_position_m[j]
        rear = front - length_m[j]
        if rear > ego_position:
            if rear < nearest_rear[row]:
                nearest_rear[row], front_speed[row] = rear, speed_mps[j]
        elif front < ego_rear and front > nearest_front[row]:
            nearest_front[row], rear_speed[row] = front, speed_mps[j]
    for row in range(3):
        at = start + 4 * row
        if not 0 <= lowest + row < lanes:
            observation[at:at + 4] = 0.0
            continue
        _seen_gap(nearest_rear[row] - ego_position, front_speed[row] - ego_speed, range_m, v_max_mps, observation, at)
        _seen_gap(ego_rear - nearest_front[row], rear_speed[row] - ego_speed, range_m, v_max_mps, observation, at + 2)


@jit
def _seen_gap(gap_m: float, relative_speed_mps: float, range_m: float, v_max_mps: float, observation: np.ndarray,
              at: int) -> None:
    """Write one gap [m] / `range_m` and its relative speed [m/s] / `v_max_mps` at `at`: (1, 0) beyond `range_m`."""
    if gap_m <= range_m:
        observation[at] = min(max(gap_m, 0.0) / range_m, 1.0)
        observation[at + 1] = min(max(relative_speed_mps / v_max_mps, -1.0), 1.0)
    else:
        observation[at], observation[at + 1] = 1.0, 0.0


@jit
def observation_vector(front_xy: np.ndarray, heading_rad: np.ndarray, length_m: np.ndarray, width_m: np.ndarray,
                       speed_mps: np.ndarray, lane_position_m: np.ndarray, lane: np.ndarray, edges: np.ndarray,
                       front_x: float, front_y: float, heading: float, ego_length: float, ego_speed: float,
                       set_point: float, ego_position: float, ego_lane: int, changing: bool, beams: int,
                       range_m: float, v_min_mps: float, v_max_mps: float, lanes: int, lane_block: bool,
                       route_block: bool, lane_end: float, lane_offset: float, merge_ahead: float,
                       diverge_ahead: float) -> np.ndarray:
    """The float32 observation (layout in `observation`) from the neighbours' front bumpers [m], headings [rad],
    sizes [m], speeds [m/s], fronts along the route [m] and route lanes, the road-edge boxes (S, 6) rows of centre x,
    y, unit axis x, y, half length and 0 [m], and the ego's front x, y [m], heading [rad], length [m], speed [m/s],
    cruise set-point [m/s], front along the route [m] and route lane; with `lane_block` the lane block
    (`_lane_block`) and with `route_block` the route block's four values (`route_progress.route_values`) follow."""
    width = 2 * beams + 3 + lanes
    observation = np.zeros(width + 12 * lane_block + 4 * route_block, dtype=np.float32)
    _lidar(front_xy, heading_rad, length_m, width_m, speed_mps, edges, front_x, front_y, heading, ego_length,
           ego_speed, beams, range_m, v_max_mps, observation)
    observation[2 * beams] = min(max(ego_speed / v_max_mps, 0.0), 2.0)
    observation[2 * beams + 1] = (set_point - v_min_mps) / (v_max_mps - v_min_mps)
    observation[2 * beams + 2 + min(max(ego_lane, 0), lanes - 1)] = 1.0  # an acceleration lane or ramp reads as 0
    observation[width - 1] = 1.0 if changing else 0.0
    if lane_block:
        _lane_block(lane_position_m, length_m, lane, speed_mps, ego_position, ego_length, ego_speed, ego_lane, lanes,
                    range_m, v_max_mps, observation, width)
    if route_block:
        at = width + 12 * lane_block
        observation[at], observation[at + 1] = lane_end, lane_offset
        observation[at + 2], observation[at + 3] = merge_ahead, diverge_ahead
    return observation
