"""Bird's-eye frames of the ego's surroundings, drawn with Pillow into a numpy RGB array (no display needed).

A frame shows the road around the ego (its edges solid, lane markings dashed), every vehicle the ego's context
subscription knows as its oriented rectangle coloured by SUMO vehicle type, the ego in red with a white outline,
the LIDAR beams from the ego's centre to what they hit (a dot at each hit), and a text band with the time,
speed, set-point, lane and last action. The view follows the ego along the road, which keeps a fixed place in
the frame; `pixels_per_m` sets the scale. `FrameRenderer.draw` is a pure function of its arguments and the
road geometry given at construction.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sumo_rail.sim.simulation import EgoState, Neighbours

Colour = tuple[int, int, int]

BACKGROUND: Colour = (46, 110, 52)
ROAD: Colour = (72, 72, 76)
MARKING: Colour = (235, 235, 235)
TEXT_BAND: Colour = (20, 20, 24)
TEXT: Colour = (245, 245, 245)
BEAM: Colour = (120, 220, 255)
HIT: Colour = (255, 210, 40)
EGO: Colour = (230, 30, 30)
TYPE_COLOURS: dict[str, Colour] = {"car": (70, 130, 220), "sports_car": (200, 90, 220), "truck": (235, 150, 40)}
"""Fill colour of each SUMO vehicle type of networks/traffic.rou.xml; other types are drawn in `OTHER`."""
OTHER: Colour = (170, 170, 170)

_TEXT_BAND_PX = 30
_MARGIN_PX = 24
_DASH_M, _GAP_M = 6.0, 6.0


@dataclass(frozen=True)
class FrameText:
    """What the text band says about the last decision."""

    time_s: float
    speed_mps: float
    set_point_mps: float
    """The cruise set-point [m/s]; NaN (not shown) under the acceleration interface, whose `action` says the
    acceleration."""
    lane: int
    lanes: int
    action: str
    decision: int

    def line(self) -> str:
        """The band's one line, speeds in km/h, lanes counted from 0 = rightmost."""
        set_point = "" if math.isnan(self.set_point_mps) else f"set-point {self.set_point_mps * 3.6:5.1f} km/h   "
        return (f"t {self.time_s:6.1f} s   speed {self.speed_mps * 3.6:5.1f} km/h   "
                f"{set_point}lane {self.lane} (0 = rightmost of {self.lanes})   "
                f"action {self.action}   decision {self.decision}")


class FrameRenderer:
    """Draws frames of one road; `road_edges` are the road's outer edges as SUMO gives them (`Simulation.road_edges`:
    segments [m], shape (S, 2, 2), right edge first, then left)."""

    def __init__(self, road_edges: np.ndarray, lanes: int, width_px: int = 1200, pixels_per_m: float = 5.0) -> None:
        half = len(road_edges) // 2
        right, left = road_edges[:half], road_edges[half:]
        start, end = right[0, 0], right[-1, 1]
        self.direction = (end - start) / np.linalg.norm(end - start)
        """Unit vector along the road (its direction of travel)."""
        self.normal = np.array([-self.direction[1], self.direction[0]])
        """Unit vector across the road, to the left of travel."""
        self.origin = start
        """A point of the right edge [m]: across-road offsets are measured from it."""
        self.road_width_m = float((left[0, 0] - start) @ self.normal)
        self.lanes = lanes
        self.scale = pixels_per_m
        self.width = width_px
        road_px = self.road_width_m * pixels_per_m
        self.height = int(math.ceil((_TEXT_BAND_PX + 2 * _MARGIN_PX + road_px) / 16.0) * 16)
        """Frame height [px], a multiple of 16 (what video encoders want), as is a width of 1200."""
        self._road_bottom_px = _TEXT_BAND_PX + (self.height - _TEXT_BAND_PX + road_px) / 2.0
        self._dash_period_px = max(2, round((_DASH_M + _GAP_M) * pixels_per_m))
        self._background = self._road_background()
        self._text = _GlyphText(_font())

    def to_pixels(self, points_m: np.ndarray, ego_along_m: float) -> np.ndarray:
        """World points [m], shape (..., 2), to pixel coordinates (x right along the road, y down), with the
        ego's position along the road `ego_along_m` [m] at the frame's horizontal centre."""
        relative = points_m - self.origin
        along = relative @ self.direction - ego_along_m
        across = relative @ self.normal
        return np.stack([self.width / 2.0 + along * self.scale, self._road_bottom_px - across * self.scale], axis=-1)

    def draw(self, ego: EgoState, neighbours: Neighbours, types: Sequence[str], distances_m: np.ndarray,
             range_m: float, text: FrameText) -> np.ndarray:
        """One frame, shape (height, width, 3) uint8. `types` holds each neighbour's SUMO type; `distances_m`
        the LIDAR distance of each beam [m] (beam i at heading + i * 360/beams degrees, counter-clockwise);
        `range_m` the LIDAR range (a beam reading it hit nothing)."""
        ego_centre = _centre(np.array([ego.front_x, ego.front_y]), ego.heading_rad, ego.length_m)
        image, ego_along = self._road_under(ego_centre)
        draw = ImageDraw.Draw(image)
        if len(neighbours.ids):
            centres = neighbours.front_xy - 0.5 * neighbours.length_m[:, None] * _unit(neighbours.heading_rad)
            corners = _corners(centres, neighbours.heading_rad, neighbours.length_m, neighbours.width_m)
            for polygon, kind in zip(self.to_pixels(corners, ego_along), types, strict=True):
                draw.polygon([tuple(p) for p in polygon], fill=TYPE_COLOURS.get(kind, OTHER), outline=(15, 15, 15))
        self._draw_beams(draw, ego_centre, ego.heading_rad, distances_m, range_m, ego_along)
        ego_corners = _corners(ego_centre[None], np.array([ego.heading_rad]), np.array([ego.length_m]),
                               np.array([ego.width_m]))
        draw.polygon([tuple(p) for p in self.to_pixels(ego_corners, ego_along)[0]], fill=EGO, outline=(255, 255, 255))
        self._text.draw(image, (10, _TEXT_BAND_PX // 2), text.line(), TEXT)
        return np.asarray(image)

    def _road_under(self, ego_centre: np.ndarray) -> tuple[Image.Image, float]:
        """The road around the ego's centre [m] and where the ego is along it [m] (what `to_pixels` takes): the road
        scrolls under the ego, a crop of the pre-drawn road shifted by the ego's position."""
        ego_along = float((ego_centre - self.origin) @ self.direction)
        offset = round(ego_along * self.scale) % self._dash_period_px
        return self._background.crop((offset, 0, offset + self.width, self.height)), ego_along

    def _road_background(self) -> Image.Image:
        """The grass, the road, its edges and lane markings, one dash period wider than a frame; the text band."""
        width = self.width + self._dash_period_px
        image = Image.new("RGB", (width, self.height), BACKGROUND)
        draw = ImageDraw.Draw(image)
        top = self._road_bottom_px - self.road_width_m * self.scale
        draw.rectangle((0, top, width, self._road_bottom_px), fill=ROAD)
        for y in (top, self._road_bottom_px):
            draw.line((0, y, width, y), fill=MARKING, width=2)
        dash_px = self._dash_period_px * _DASH_M / (_DASH_M + _GAP_M)
        lane_px = self.road_width_m * self.scale / self.lanes
        for lane in range(1, self.lanes):
            y = self._road_bottom_px - lane * lane_px
            # dashes fixed to the road: the crop at `offset` shows road metre (ego_along - width/2/scale) at x=0
            for x in range(-self.width // 2 % self._dash_period_px - self._dash_period_px, width,
                           self._dash_period_px):
                draw.line((x, y, x + dash_px, y), fill=MARKING, width=1)
        draw.rectangle((0, 0, width, _TEXT_BAND_PX - 1), fill=TEXT_BAND)
        return image

    def _draw_beams(self, draw: ImageDraw.ImageDraw, centre: np.ndarray, heading_rad: float, distances_m: np.ndarray,
                    range_m: float, ego_along: float) -> None:
        angles = heading_rad + np.arange(len(distances_m)) * (2.0 * math.pi / len(distances_m))
        ends = centre + distances_m[:, None] * _unit(angles)
        origin = self.to_pixels(centre, ego_along)
        for end, distance in zip(self.to_pixels(ends, ego_along), distances_m, strict=True):
            draw.line((*origin, *end), fill=BEAM, width=1)
            if distance < range_m - 1e-6:
                x, y = end
                draw.ellipse((x - 2.5, y - 2.5, x + 2.5, y + 2.5), fill=HIT)


def legend() -> Mapping[str, Colour]:
    """What each colour means, for captions."""
    return {"ego": EGO, **TYPE_COLOURS, "other type": OTHER, "LIDAR beam": BEAM, "LIDAR hit": HIT}


def _unit(angles_rad: np.ndarray | float) -> np.ndarray:
    angles = np.asarray(angles_rad, dtype=np.float64)
    return np.stack([np.cos(angles), np.sin(angles)], axis=-1)


def _centre(front_xy: np.ndarray, heading_rad: float, length_m: float) -> np.ndarray:
    return front_xy - 0.5 * length_m * _unit(heading_rad)


def _corners(centres: np.ndarray, headings: np.ndarray, lengths: np.ndarray, widths: np.ndarray) -> np.ndarray:
    """Corners of oriented rectangles [m], shape (M, 4, 2), going round each one."""
    axis = _unit(headings)
    side = np.stack([-axis[:, 1], axis[:, 0]], axis=1)
    half_l = 0.5 * lengths[:, None] * axis
    half_w = 0.5 * widths[:, None] * side
    return np.stack([centres + half_l + half_w, centres + half_l - half_w, centres - half_l - half_w,
                     centres - half_l + half_w], axis=1)


class _GlyphText:
    """Text drawn from glyphs rendered once each: FreeType layout of a whole line costs ~1.5 ms a frame."""

    def __init__(self, font: ImageFont.ImageFont | ImageFont.FreeTypeFont) -> None:
        self._font = font
        self._glyphs: dict[str, tuple[Image.Image | None, int, int]] = {}
        _, top, _, bottom = font.getbbox("0Ag")
        self._ascent = int(bottom - top)

    def _glyph(self, char: str) -> tuple[Image.Image | None, int, int]:
        """The glyph's mask (None for blank ones), its left offset and its advance [px]."""
        if char not in self._glyphs:
            left, _, right, bottom = (int(v) for v in self._font.getbbox(char))
            advance = round(self._font.getlength(char))
            mask = None
            if right > left and bottom > 0:
                mask = Image.new("L", (right - left, self._ascent + 4), 0)
                ImageDraw.Draw(mask).text((-left, 0), char, fill=255, font=self._font)
            self._glyphs[char] = (mask, left, advance)
        return self._glyphs[char]

    def draw(self, image: Image.Image, centre_left: tuple[int, int], text: str, colour: Colour) -> None:
        """Draw `text` starting at x, vertically centred on y [px]."""
        x, y = centre_left
        top = y - self._ascent // 2 - 2
        for char in text:
            mask, left, advance = self._glyph(char)
            if mask is not None:
                image.paste(colour, (x + left, top), mask)
            x += advance


def _font() -> ImageFont.ImageFont | ImageFont.FreeTypeFont:
    try:
        return ImageFont.load_default(size=15)
    except (TypeError, OSError):  # Pillow without FreeType: the fixed bitmap font
        return ImageFont.load_default()
