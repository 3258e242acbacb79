"""Bird's-eye frames of roads that bend, branch and lose lanes: `FrameRenderer`'s frame (vehicles, the ego, its
LIDAR, the text band) over a map of the network's lanes as SUMO shapes them, drawn around the ego each frame with
north up. The straight road keeps `FrameRenderer`'s scrolling strip."""

from __future__ import annotations

import math

import numpy as np
from PIL import Image, ImageDraw

from sumo_rail.sim.network import offset_polyline
from sumo_rail.sim.render import _TEXT_BAND_PX, BACKGROUND, MARKING, ROAD, TEXT_BAND, FrameRenderer, _font, _GlyphText

LaneShape = tuple[np.ndarray, float, bool]
"""A lane's centre line [m], shape (N, 2), its width [m], and whether it is an edge's outermost lane on a side."""
LANE_LINE: tuple[int, int, int] = (150, 150, 150)


class MapRenderer(FrameRenderer):
    """Frames of any road: `lanes` are every lane's shape (`Sensing.lane_shapes`); the view, `height_m` [m] tall and
    1200 px wide at `pixels_per_m`, is centred on the ego."""

    def __init__(self, lanes: list[LaneShape], lane_count: int, width_px: int = 1200, pixels_per_m: float = 5.0,
                 height_m: float = 90.0) -> None:
        self.lanes = lane_count
        self.scale = pixels_per_m
        self.width = width_px
        self.height = int(math.ceil((_TEXT_BAND_PX + height_m * pixels_per_m) / 16.0) * 16)
        self._centre_y_px = _TEXT_BAND_PX + (self.height - _TEXT_BAND_PX) / 2.0
        self._polygons = [np.concatenate([offset_polyline(shape, width / 2), offset_polyline(shape, -width / 2)[::-1]])
                          for shape, width, _ in lanes if len(shape) >= 2]
        self._lines = [(offset_polyline(shape, side * width / 2), outer)
                       for shape, width, outer in lanes if len(shape) >= 2 for side in (-1, 1)]
        self._reach_m = math.hypot(width_px, self.height) / pixels_per_m
        self._text = _GlyphText(_font())

    def to_pixels(self, points_m: np.ndarray, ego_centre: np.ndarray) -> np.ndarray:  # type: ignore[override]
        """World points [m], shape (..., 2), to pixels (x right = east, y down = south) around the ego's centre."""
        relative = np.asarray(points_m) - ego_centre
        return np.stack([self.width / 2.0 + relative[..., 0] * self.scale,
                         self._centre_y_px - relative[..., 1] * self.scale], axis=-1)

    def _road_under(self, ego_centre: np.ndarray) -> tuple[Image.Image, np.ndarray]:  # type: ignore[override]
        image = Image.new("RGB", (self.width, self.height), BACKGROUND)
        draw = ImageDraw.Draw(image)
        for polygon in self._near(self._polygons, ego_centre):
            draw.polygon([tuple(point) for point in self.to_pixels(polygon, ego_centre)], fill=ROAD)
        for line, outer in self._lines:
            if self._is_near(line, ego_centre):
                points = [tuple(point) for point in self.to_pixels(line, ego_centre)]
                draw.line(points, fill=MARKING if outer else LANE_LINE, width=2 if outer else 1)
        draw.rectangle((0, 0, self.width, _TEXT_BAND_PX - 1), fill=TEXT_BAND)
        return image, ego_centre

    def _near(self, shapes: list[np.ndarray], centre: np.ndarray) -> list[np.ndarray]:
        return [shape for shape in shapes if self._is_near(shape, centre)]

    def _is_near(self, shape: np.ndarray, centre: np.ndarray) -> bool:
        """Some of the shape's bounding box lies within the view's reach of `centre`."""
        low, high = shape.min(axis=0), shape.max(axis=0)
        return bool(np.all(low - self._reach_m <= centre) and np.all(centre <= high + self._reach_m))
