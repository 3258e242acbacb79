"""The road's outer edges across junctions, where a road joins, splits or loses lanes.

`Sensing.road_edges` gives the outer sides of every edge; between two edges lies their junction, whose area SUMO
shapes as a polygon. The sides of that polygon are the road's edge there, except the mouths, where the edges'
lanes enter or leave it: without the other sides the LIDAR's beams pass out of the road through every junction
(beside a lane drop, at a merge, at an exit's diverge). A junction with no road in or none out (a road's start or
end, the straight road's only junctions) has no walls, as before.
"""

from __future__ import annotations

import itertools

import numpy as np

MOUTH_TOLERANCE_M = 0.1
"""A point of a junction's side this close to an edge's end or start cross-section lies in a mouth [m]."""
STEP_M = 0.25
"""How finely a junction's side is tested for mouths [m] (a side may span several edges' mouths)."""


def mouth_distance(points: np.ndarray, mouth: np.ndarray) -> np.ndarray:
    """Distance of each point (N, 2) from the segment `mouth` (2, 2) [m]."""
    start, end = mouth
    along = end - start
    t = np.clip((points - start) @ along / max(float(along @ along), 1e-12), 0.0, 1.0)
    return np.linalg.norm(points - (start + t[:, None] * along), axis=1)


def junction_walls(polygon: np.ndarray, mouths: list[np.ndarray]) -> np.ndarray:
    """The parts of a junction polygon's (N, 2) sides outside its mouths (each a segment (2, 2) across an edge's end
    or start, from its right side to its left), as segments, shape (S, 2, 2)."""
    if len(polygon) < 2 or not mouths:
        return np.empty((0, 2, 2))
    closed = polygon if np.allclose(polygon[0], polygon[-1]) else np.vstack([polygon, polygon[:1]])
    walls = []
    for start, end in itertools.pairwise(closed):
        samples = int(np.ceil(np.linalg.norm(end - start) / STEP_M)) + 1
        points = start + np.linspace(0.0, 1.0, samples)[:, None] * (end - start)
        covered = np.min([mouth_distance(points, mouth) for mouth in mouths], axis=0) <= MOUTH_TOLERANCE_M
        open_piece = ~(covered[:-1] & covered[1:])
        # each run of consecutive pieces outside the mouths is one wall, one sample longer at each end (as far as
        # the side goes), so that it meets the edges' sides
        edges = np.diff(np.concatenate([[0], open_piece.astype(np.int8), [0]]))
        walls += [(points[max(first - 1, 0)], points[min(last + 1, samples - 1)])
                  for first, last in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)]
    return np.array(walls, dtype=np.float64).reshape(-1, 2, 2)
