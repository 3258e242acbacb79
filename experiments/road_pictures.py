"""A bird's-eye frame of each road near its feature, the expert driving (docs/scenarios.md and the README).
Usage: python experiments/road_pictures.py OUT_DIR   (writes road_KIND.png for every generated road)"""

from __future__ import annotations

from pathlib import Path

import click
from PIL import Image

from sumo_rail.config import FEATURE_KINDS, Config
from sumo_rail.drivers.expert import make_expert
from sumo_rail.sim.env import HighwayEnv

AHEAD_OF_FEATURE_M = {"straight": 0.0, "merge": 30.0, "merge_from_ramp": 60.0, "lane_drop": 60.0, "exit": 50.0}
"""How far before the feature's start the frame is taken [m]."""


def picture(kind: str, out: Path, seed: int = 3) -> None:
    config = Config.preset("recommended").with_overrides({"scenario": {"kind": kind}})
    at_m = (config.scenario.feature_at_m if kind in FEATURE_KINDS else 1000.0) - AHEAD_OF_FEATURE_M[kind]
    env = HighwayEnv(config, render_mode="rgb_array")
    expert = make_expert("normal", config.env.speed_step_mps, config.expert.view_range_m)
    try:
        observation, _ = env.reset(seed=seed)
        while env.traffic.ego.lane_position_m < at_m:
            observation, _, terminated, truncated, _ = env.step(expert(observation, env.traffic))
            if terminated or truncated:
                break
        Image.fromarray(env.render()).save(out / f"road_{kind}.png")
    finally:
        env.close()


@click.command(help=__doc__)
@click.argument("folder", type=click.Path(file_okay=False, path_type=Path))
def cli(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("straight", *FEATURE_KINDS):
        picture(name, folder)


if __name__ == "__main__":
    cli()
