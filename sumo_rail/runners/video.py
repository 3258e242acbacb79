"""Videos of episodes: a recorder that keeps the env's bird's-eye frame after the reset and after each decision,
and MP4/GIF encoding with imageio and its bundled ffmpeg (the optional extra `sumo-rail[video]`).

Frames come one per decision, so a video played at `1 / decision_period_s` frames per second runs in real time.
Encoding happens where the episode ran and the bytes travel back with its result, so the process that asked for
the video writes it (atomically), whichever backend ran the episode.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import cast

import numpy as np

from sumo_rail.datasets import write_bytes_atomically, write_failures, written_atomically
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.observers import Moment

INSTALL_HINT = "pip install 'sumo-rail[video]'"


class VideoError(RuntimeError):
    """A video cannot be encoded, read or written (message is one sentence)."""


def require_encoder() -> None:
    """Raise VideoError with the install hint unless imageio and its ffmpeg binary are importable."""
    try:
        import imageio.v2  # noqa: F401
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError) as error:
        raise VideoError(f"videos need imageio and imageio-ffmpeg, which are not usable here ({error}); "
                         f"install them with {INSTALL_HINT}") from error


class FrameRecorder:
    """An observer of a HighwayEnv's episode (`HighwayEnv.watching`): after its reset and each decision it keeps
    `env.frame()` in `frames` (a reset starts them again)."""

    every_step = False

    def __init__(self, env: HighwayEnv) -> None:
        self.env = env
        self.frames: list[np.ndarray] = []

    def __call__(self, moment: Moment) -> None:
        if moment.kind == "reset":
            self.frames = []
        self.frames.append(self.env.frame())


def encode_mp4(frames: Sequence[np.ndarray], fps: float) -> bytes:
    """H.264 MP4 of RGB frames (all the same shape, sides multiples of 16) at `fps` frames per second."""
    require_encoder()
    import imageio.v2 as imageio

    with tempfile.TemporaryDirectory(prefix="sumo-rail-video-") as scratch:
        path = Path(scratch) / "episode.mp4"
        # veryfast: a third of the default preset's time per frame, for slightly larger files
        writer = imageio.get_writer(path, format="FFMPEG", fps=fps, codec="libx264", quality=7, pixelformat="yuv420p",
                                    macro_block_size=16, ffmpeg_params=["-preset", "veryfast"])
        with writer:  # not `as`: imageio's stub types __enter__ as the base class, without append_data
            for frame in frames:
                writer.append_data(frame)
        return path.read_bytes()


def read_frames(path: Path, count: int | None = None) -> list[np.ndarray]:
    """The first `count` frames (all when None) of a video file, as RGB arrays."""
    require_encoder()
    import imageio.v2 as imageio

    try:
        reader = imageio.get_reader(path, format="FFMPEG")
        with reader:
            frames = []
            # imageio's stub types the reader's __iter__ as returning one array; it yields the frames
            for frame in cast(Iterable[np.ndarray], reader):
                frames.append(np.asarray(frame))
                if count is not None and len(frames) >= count:
                    break
            return frames
    except (OSError, RuntimeError) as error:
        raise VideoError(f"cannot read video {path}: {error}") from error


def video_fps(path: Path) -> float:
    """Frames per second of a video file."""
    require_encoder()
    import imageio.v2 as imageio

    try:
        reader = imageio.get_reader(path, format="FFMPEG")
        with reader:  # not `as`: imageio's stub types __enter__ as the base class, without get_meta_data
            return float(reader.get_meta_data()["fps"])
    except (OSError, RuntimeError, KeyError) as error:
        raise VideoError(f"cannot read video {path}: {error}") from error


def write_gif(frames: Sequence[np.ndarray], path: Path, fps: float) -> None:
    """An endlessly looping GIF of RGB frames at `fps`, written atomically."""
    require_encoder()
    import imageio.v2 as imageio

    with write_failures(path, VideoError), written_atomically(path, suffix=".gif") as temporary:
        imageio.mimsave(temporary, list(frames), format="GIF", duration=1000.0 / fps, loop=0)


def write_bytes(content: bytes, path: Path) -> None:
    """Write `content` to `path` atomically (`written_atomically`)."""
    with write_failures(path, VideoError):
        write_bytes_atomically(path, content)


def video_name(driver: str, episode: int, seed: int) -> str:
    """File name of one driver's episode video: the driver's name made safe for file names."""
    safe = re.sub(r"[^A-Za-z0-9._-]+", "_", driver).strip("_") or "driver"
    return f"{safe}_episode{episode:03d}_seed{seed}.mp4"
