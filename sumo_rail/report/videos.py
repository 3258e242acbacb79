"""Side-by-side GIFs for the report: a driver's episode above the expert's on the same seed, from the MP4s that
`evaluate --video` wrote (one bird's-eye frame per decision)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from sumo_rail.report.inputs import ReportError

VIDEO_NAME = re.compile(r"^(?P<driver>.+)_episode(?P<episode>\d+)_seed(?P<seed>\d+)\.mp4$")
GIF_FRAMES = 60
"""Decisions shown per GIF (30 s of driving at the default 0.5 s decision period)."""
GIF_SPEED_UP = 2.0
"""GIFs play at this multiple of real time."""


@dataclass(frozen=True)
class Comparison:
    """One GIF written: `driver` above `expert` on the same episode and seed."""

    file: str
    driver: str
    expert: str
    episode: int
    seed: int


def comparison_gifs(video_dir: Path, out: Path, frames: int = GIF_FRAMES) -> list[Comparison]:
    """For every episode with a video of an expert and of other drivers, one GIF per other driver: its first
    `frames` frames above the expert's, at half size, into `out`, at `GIF_SPEED_UP` x the videos' frame rate."""
    from sumo_rail.runners.video import VideoError, read_frames, require_encoder, video_fps, write_gif

    try:
        require_encoder()
    except VideoError as error:
        raise ReportError(str(error)) from error
    videos: dict[tuple[int, int], dict[str, Path]] = {}
    for path in sorted(Path(video_dir).glob("*.mp4")):
        match = VIDEO_NAME.match(path.name)
        if match:
            key = (int(match["episode"]), int(match["seed"]))
            videos.setdefault(key, {})[match["driver"]] = path
    if not videos:
        raise ReportError(f"{video_dir} holds no videos written by evaluate --video")
    written = []
    for (episode, seed), drivers in sorted(videos.items()):
        experts = sorted(name for name in drivers if name.startswith("expert"))
        if not experts:
            continue
        expert = experts[0]
        for driver in sorted(set(drivers) - {expert}):
            try:
                top, bottom = read_frames(drivers[driver], frames), read_frames(drivers[expert], frames)
            except VideoError as error:
                raise ReportError(str(error)) from error
            stacked = [_stack(a, driver, b, expert) for a, b in zip(top, bottom, strict=False)]
            name = f"video_{driver}_vs_{expert}_episode{episode:03d}.gif"
            try:
                write_gif(stacked, out / name, GIF_SPEED_UP * video_fps(drivers[expert]))
            except VideoError as error:
                raise ReportError(str(error)) from error
            written.append(Comparison(name, driver, expert, episode, seed))
    return written


def _stack(top: np.ndarray, top_name: str, bottom: np.ndarray, bottom_name: str) -> np.ndarray:
    """Two frames one above the other at half size, each labelled with its driver at the right of its band."""
    halves = []
    for frame, name in ((top, top_name), (bottom, bottom_name)):
        image = Image.fromarray(frame)
        ImageDraw.Draw(image).text((image.width - 10, 15), name, fill=(255, 230, 0), anchor="rm")
        halves.append(np.asarray(image.resize((image.width // 2, image.height // 2), Image.Resampling.BILINEAR)))
    separator = np.full((4, halves[0].shape[1], 3), 255, dtype=np.uint8)
    return np.concatenate([halves[0], separator, halves[1]])
