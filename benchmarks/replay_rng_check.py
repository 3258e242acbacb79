"""Do a recorded scene's episodes depend on SUMO's random number generators? bench_replay's scenes and seats, each
episode run three ways: reset by a fresh load with the seat's SUMO seed (as the episodes run), by a fresh load with
another seed, and by a `loadState` of the empty road saved after the first load (bench_replay_floor's shortcut: it
does not reseed). Drivers: keep, the rule-based expert, uniformly random actions (many lane changes) and SUMO's IDM
(`sumo-idm`). Compared: every vehicle's position, angle, speed, acceleration, lane, lane position and lateral offset
after every SUMO step, and the episode's metrics; the first difference is printed. With `--speed-factor F` every
replayed vehicle is given speed factor F as it enters (the episodes do not do that: they keep the factor SUMO draws
from the default type's distribution as the vehicle is added).
Usage: `python benchmarks/replay_rng_check.py [--seats 20] [--reactive] [--speed-factor 2.0]` (docs/replay.md).
"""

from __future__ import annotations

import argparse
import contextlib
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import libsumo
from bench_replay import bench_scenes, seats_of
from bench_replay_floor import state_resets
from libsumo import _libsumo as compiled

from sumo_rail.config import Config
from sumo_rail.recordings.scene import read_scene
from sumo_rail.recordings.seat import SceneEnv
from sumo_rail.runners.rollout import DriverSpec, ExpertDriver, KeepDriver, RandomDriver, SumoIdmDriver, run_episode
from sumo_rail.sim.replay import DEFAULT_TYPE

DRIVERS: dict[str, DriverSpec] = {"keep": KeepDriver(), "expert": ExpertDriver(), "random": RandomDriver(),
                                  "sumo-idm": SumoIdmDriver()}


class EveryVehicle:
    """Every vehicle's state after every SUMO step."""

    every_step = True

    def __init__(self) -> None:
        self.steps: list[tuple[float, list[tuple[Any, ...]]]] = []

    def __call__(self, moment: Any) -> None:
        v = libsumo.vehicle
        self.steps.append((moment.time_s, [(name, v.getPosition(name), v.getAngle(name), v.getSpeed(name),
                                            v.getAcceleration(name), v.getLaneID(name), v.getLanePosition(name),
                                            v.getLateralLanePosition(name)) for name in v.getIDList()]))


@contextlib.contextmanager
def other_seed(seed: int) -> Iterator[None]:
    """Within the block, every load of SUMO takes `--seed seed`."""
    load = compiled.simulation_load

    def load_seeded(args: list[str]) -> None:
        load([*args[:args.index("--seed") + 1], str(seed), *args[args.index("--seed") + 2:]])

    compiled.simulation_load = load_seeded
    try:
        yield
    finally:
        compiled.simulation_load = load


@contextlib.contextmanager
def speed_factor(factor: float | None) -> Iterator[None]:
    """Within the block (with `factor`), a vehicle added of SUMO's default type gets speed factor `factor`."""
    add = compiled.vehicle_add

    def add_fixed(*args: Any, **kwargs: Any) -> None:
        add(*args, **kwargs)
        if kwargs.get("typeID", args[2] if len(args) > 2 else DEFAULT_TYPE) == DEFAULT_TYPE:
            compiled.vehicle_setSpeedFactor(args[0], factor)

    if factor is not None:
        compiled.vehicle_add = add_fixed
    try:
        yield
    finally:
        compiled.vehicle_add = add


def first_difference(a: Any, b: Any) -> str:
    """Where two episodes' rows first differ ('' where they do not)."""
    for (time_s, rows_a), (_, rows_b) in zip(a[0], b[0], strict=False):
        if rows_a != rows_b:
            other = {row[0]: row for row in rows_b}
            row = next(row for row in rows_a if other.get(row[0]) != row)
            return f"at {time_s:g} s, vehicle {row[0]}: {row[1:]} against {other.get(row[0], ('absent',))[1:]}"
    return "" if a == b else "in the metrics"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seats", type=int, default=20)
    parser.add_argument("--reactive", action="store_true")
    parser.add_argument("--speed-factor", type=float, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        for label, path, lanes, horizon_s in bench_scenes(Path(folder)):
            scene = read_scene(path)
            config = Config.from_dict({"scenario": {"lanes": lanes}, "env": {"max_episode_s": horizon_s}})
            seats = seats_of(scene, args.seats, horizon_s)
            runs: dict[str, dict[tuple[str, int], Any]] = {}
            for way, resets in (("fresh", contextlib.nullcontext), ("other seed", lambda: other_seed(12345)),
                                ("loadState", lambda: state_resets(Path(folder)))):
                with resets(), speed_factor(args.speed_factor):
                    env = SceneEnv(config, scene, reactive=args.reactive, transport="libsumo")
                    try:
                        env.reset(seed=0, options={"vehicle": seats[0][0], "start_s": seats[0][1]})  # SUMO started
                        runs[way] = {}
                        for name, spec in DRIVERS.items():
                            for k, (vehicle, start_s) in enumerate(seats):
                                options: dict[str, Any] = {"vehicle": vehicle, "start_s": start_s}
                                if isinstance(spec, SumoIdmDriver):
                                    options["controller"] = spec.controller
                                with env.simulation.watching(EveryVehicle()) as watched:
                                    episode = run_episode(env, spec.create(config, k), 100 + k, options=options)
                                runs[way][name, k] = (watched.steps, episode.metrics)
                    finally:
                        env.close()
            for name in DRIVERS:
                for way in ("other seed", "loadState"):
                    differences = [first_difference(runs["fresh"][name, k], runs[way][name, k])
                                   for k in range(len(seats))]
                    first = next((each for each in differences if each), "none")
                    print(f"{label}, {'reactive' if args.reactive else 'non-reactive'}, {name}: {way}: "
                          f"{sum(not each for each in differences)}/{len(seats)} episodes the same; first "
                          f"difference: {first}", flush=True)


if __name__ == "__main__":
    main()
