"""The README's pictures: a sumo-gui screenshot (docs/images/gui.png) and a frame of the MP4 video of the same
moment (docs/images/frame.png, as evaluate --video encodes it), the normal expert driving evaluation episode 0 of
the default scenario.

Needs a display for sumo-gui: `xvfb-run -s "-screen 0 1280x800x24" python experiments/readme_pictures.py`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from PIL import Image

from sumo_rail.config import Config
from sumo_rail.drivers.expert import make_expert
from sumo_rail.runners.video import encode_mp4, read_frames, write_bytes
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.env import HighwayEnv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--decision", type=int, default=40, help="decision at which both pictures are taken")
    parser.add_argument("--out", type=Path, default=Path("docs/images"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    config = Config()
    seed = episode_seeds(Purpose.EVALUATE, 1000, 1)[0]
    env = HighwayEnv(config, render_mode="human", gui_delay_ms=0)
    expert = make_expert("normal", config.env.speed_step_mps)
    try:
        observation, _ = env.reset(seed=seed, options={"pool": "test", "warm_state": 0})
        frames = [env.frame()]
        for _ in range(args.decision):
            observation, *_ = env.step(expert(observation, env.traffic))
            frames.append(env.frame())
        video = args.out / ".frames.mp4"
        write_bytes(encode_mp4(frames, 1.0 / config.env.decision_period_s), video)
        Image.fromarray(read_frames(video)[args.decision]).save(args.out / "frame.png", optimize=True)
        video.unlink()
        env.gui_screenshot(args.out / "gui.png")
        env.step(expert(observation, env.traffic))  # sumo-gui saves the screenshot when it draws this step
    finally:
        env.close()
    shot = Image.open(args.out / "gui.png")  # 1280x800, the road across its middle: keep the middle band
    shot.crop((0, shot.height // 2 - 180, shot.width, shot.height // 2 + 180)).save(args.out / "gui.png", optimize=True)
    print(f"wrote {args.out / 'gui.png'} and {args.out / 'frame.png'} (seed {seed}, decision {args.decision})")


if __name__ == "__main__":
    main()
