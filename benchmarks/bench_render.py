"""Benchmark: what watching costs. Bird's-eye frames (render_mode="rgb_array") against the env's own step, MP4
encoding per frame, and the wall time of a sumo-gui episode (when a display is available).

Runs the normal expert on the default scenario; medians over every decision of `--episodes` episodes.
Writes its section of docs/benchmarks.md (between markers) with the command and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from doc_section import write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.expert import make_expert
from sumo_rail.runners.video import encode_mp4
from sumo_rail.sim.env import HighwayEnv


def headless(config: Config, seeds: list[int]) -> tuple[list[float], list[float], list[np.ndarray]]:
    """Per decision: env.step and env.render times [s]; the frames of the last episode."""
    steps, renders = [], []
    frames: list[np.ndarray] = []
    env = HighwayEnv(config, render_mode="rgb_array")
    expert = make_expert("normal", config.env.speed_step_mps)
    try:
        for seed in seeds:
            observation, _ = env.reset(seed=seed, options={"pool": "test"})
            frames = [env.render()]
            done = False
            while not done:
                started = time.perf_counter()
                observation, _, terminated, truncated, _ = env.step(expert(observation, env.traffic))
                steps.append(time.perf_counter() - started)
                started = time.perf_counter()
                frames.append(env.render())
                renders.append(time.perf_counter() - started)
                done = terminated or truncated
    finally:
        env.close()
    return steps, renders, frames


def gui_episode_s(config: Config, seed: int, delay_ms: float) -> tuple[float, int]:
    """Wall time [s] of one sumo-gui episode (start, reset, every decision, close) and its decisions."""
    started = time.perf_counter()
    env = HighwayEnv(config, render_mode="human", gui_delay_ms=delay_ms)
    expert = make_expert("normal", config.env.speed_step_mps)
    try:
        observation, _ = env.reset(seed=seed, options={"pool": "test"})
        done = False
        while not done:
            observation, _, terminated, truncated, _ = env.step(expert(observation, env.traffic))
            done = terminated or truncated
        decisions = env.metrics.decisions
    finally:
        env.close()
    return time.perf_counter() - started, decisions


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    config = Config()
    seeds = list(range(2000, 2000 + args.episodes))
    steps, renders, frames = headless(config, seeds)
    started = time.perf_counter()
    encode_mp4(frames, 1.0 / config.env.decision_period_s)
    encode_ms = 1000.0 * (time.perf_counter() - started) / len(frames)
    step_ms, render_ms = 1000.0 * statistics.median(steps), 1000.0 * statistics.median(renders)
    rows = [f"| env.step, one decision (median) [ms] | {step_ms:.2f} |",
            f"| env.render(), one {frames[0].shape[1]}x{frames[0].shape[0]} frame (median) [ms] | {render_ms:.2f} |",
            f"| MP4 encoding (H.264, imageio-ffmpeg) per frame [ms] | {encode_ms:.2f} |",
            f"| recording overhead: (render + encode) / step | {(render_ms + encode_ms) / step_ms:.2f} |"]
    if os.environ.get("DISPLAY"):
        for delay in (0.0, 100.0):
            wall, decisions = gui_episode_s(config, seeds[0], delay)
            rows.append(f"| sumo-gui episode, --gui-delay {delay:g} ms: wall time [s] ({decisions} decisions, "
                        f"{decisions * config.env.decision_period_s:.0f} s simulated) | {wall:.1f} |")
    else:
        rows.append("| sumo-gui episode | not measured: no DISPLAY (run under xvfb-run) |")
    table = "\n".join(rows)
    section = f"""
## Watching: frames, videos and sumo-gui (issue 16)

Command: `{' '.join(['python', *sys.argv])}` (the sumo-gui rows need a display, e.g.
`xvfb-run -s "-screen 0 1280x800x24"`).
Machine: {platform.machine()}, {os.cpu_count()} cores shared with other jobs, Python {platform.python_version()},
SUMO {sumo_version()}. The normal expert on the default scenario, {args.episodes} episodes ({len(steps)} decisions).

| measure | value |
|---|---|
{table}
"""
    write_section(args.out, "render", section)


if __name__ == "__main__":
    main()
