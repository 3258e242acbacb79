"""report --videos: GIFs of a driver above the expert on the same seed, from evaluate --video's MP4s."""

import numpy as np
import pytest
from PIL import Image

from sumo_rail.report.inputs import Inputs, ReportError
from sumo_rail.report.markdown import write_report
from sumo_rail.runners.video import encode_mp4, write_bytes

pytest.importorskip("imageio_ffmpeg", reason="videos are the package's optional extra [video]")


def solid_video(path, colour, frames=8):
    """Frames of one colour below a dark band in which a white square moves (so no two frames are equal)."""
    video = np.zeros((frames, 160, 1200, 3), dtype=np.uint8)
    video[:, 40:] = colour
    for k in range(frames):
        video[k, 8:24, 100 * k + 16:100 * k + 48] = 255
    write_bytes(encode_mp4(list(video), fps=2.0), path)


def test_report_shows_each_driver_above_the_expert_on_the_same_seed(tmp_path):
    videos, out = tmp_path / "videos", tmp_path / "report"
    videos.mkdir()
    solid_video(videos / "expert-normal_episode000_seed7.mp4", (0, 0, 255))
    solid_video(videos / "keep_episode000_seed7.mp4", (255, 0, 0))
    solid_video(videos / "keep_episode001_seed8.mp4", (255, 0, 0))  # no expert on this seed: no GIF
    report = write_report(Inputs([], None, []), out, videos)
    gif = out / "video_keep_vs_expert-normal_episode000.gif"
    assert "(video_keep_vs_expert-normal_episode000.gif)" in report.read_text()
    assert sorted(path.name for path in out.glob("*.gif")) == [gif.name]
    image = Image.open(gif)
    assert image.n_frames == 8 and image.info["duration"] == 250  # 2 frames/s played at twice real time
    pixels = np.asarray(image.convert("RGB")).astype(int)
    top, bottom = pixels[pixels.shape[0] // 4 + 10], pixels[3 * pixels.shape[0] // 4 + 10]
    assert top[300, 0] > 200 and top[300, 2] < 60  # the driver (red here) above
    assert bottom[300, 2] > 200 and bottom[300, 0] < 60  # the expert (blue here) below


def test_a_folder_without_videos_is_a_report_error(tmp_path):
    with pytest.raises(ReportError, match="holds no videos written by evaluate --video"):
        write_report(Inputs([], None, []), tmp_path / "report", tmp_path)
