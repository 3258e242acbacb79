"""Benchmark: the floor of a closed-loop episode in a recorded scene, measured: SUMO's own parts of bench_replay's
episodes (the same scenes, seats and keep episodes) with every shortcut taken, those that change results included, and
no Python at all, against raw SUMO stepping of the same scene. The shortcuts, which the episodes do NOT take:

- a reset by `simulation.loadState` of the empty road saved after the first load (its clock set to the seat's), in
  place of a fresh load: it does not reseed SUMO's random number generators (docs/replay.md says which draws change);
- each replayed vehicle moved by `moveTo` on its recorded lane and lane position in place of `moveToXY` at its
  recorded x, y: its lateral offset in the lane is lost. Costed per call on the same vehicles (the loop of
  `move_costs`), the moves' time scaled by the ratio.

Writes its section of docs/benchmarks.md. Usage: `python benchmarks/bench_replay_floor.py [--seats 30] [--rounds 3]`.
"""

from __future__ import annotations

import argparse
import contextlib
import re
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import libsumo
import numpy as np
from bench_replay import GOAL, SUMO_PARTS, bench_scenes, breakdown, raw_speed, seats_of
from doc_section import write_section
from libsumo import _libsumo as compiled

from sumo_rail.config import Config
from sumo_rail.recordings.scene import Scene, read_scene
from sumo_rail.recordings.scene_drivers import reactive_types
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.seat import SceneEnv, scene_config
from sumo_rail.sim.replay import VehicleTypes
from sumo_rail.sim.simulation import EGO_ID, run_options

STATE_PARTS = {**SUMO_PARTS, "load": ("simulation_loadState",)}
"""The parts timed with resets by loadState (the first, real load is before the timed episodes)."""
HEADER = ("| scene | mode | simulated [s] | raw | budget | load | steps | moves | entries | SUMO now | loadState "
          "| steps | moves (moveTo) | entries | floor |\n" + "|---" * 15 + "|")


@contextlib.contextmanager
def state_resets(folder: Path) -> Iterator[None]:
    """Within the block, libsumo's load loads the road once; every later load is a `loadState` of the state saved
    after it, the clock set to the load's `--begin`."""
    load, saved = compiled.simulation_load, folder / "empty.xml"
    text: list[str] = []

    def load_by_state(args: list[str]) -> None:
        if not text:
            load(args)
            compiled.simulation_saveState(str(saved))
            text.append(saved.read_text())
            return
        begin = float(args[args.index("--begin") + 1])
        now = folder / "now.xml"
        now.write_text(re.sub(r'(<snapshot [^>]*time=")[^"]*"', rf'\g<1>{begin:.3f}"', text[0], count=1))
        compiled.simulation_loadState(str(now))

    compiled.simulation_load = load_by_state
    try:
        yield
    finally:
        compiled.simulation_load = load


def move_costs(scene: Scene, config: Config, seats: list[tuple[str, float]], types: VehicleTypes,
               repeats: int = 20) -> tuple[float, float]:
    """CPU time per call [us] of moveToXY (where each vehicle is) and of moveTo (its lane and lane position), over the
    replayed vehicles on the road one decision into each seat's non-reactive episode."""
    env = SceneEnv(config, scene, reactive=False, transport="libsumo", types=types)
    xy_s = to_s = 0.0
    calls = 0
    try:
        for vehicle, start_s in seats:
            env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
            env.step(0)
            api = libsumo.vehicle
            states = [(name, api.getRoadID(name), api.getLaneIndex(name), *api.getPosition(name), api.getAngle(name),
                       api.getLaneID(name), api.getLanePosition(name)) for name in api.getIDList() if name != EGO_ID]
            for _ in range(repeats):
                begin = time.process_time()
                for name, edge, lane, x, y, angle, _lane_id, _position in states:
                    compiled.vehicle_moveToXY(name, edge, lane, x, y, angle, 2)
                middle = time.process_time()
                for name, *_, lane_id, position in states:
                    compiled.vehicle_moveTo(name, lane_id, position, 0)
                xy_s, to_s, calls = xy_s + middle - begin, to_s + time.process_time() - middle, calls + len(states)
    finally:
        env.close()
    return 1e6 * xy_s / calls, 1e6 * to_s / calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seats", type=int, default=30, help="episodes per scene and mode")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of every measure (medians)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    rows, costs = [], []
    with tempfile.TemporaryDirectory() as folder:
        for label, path, lanes, horizon_s in bench_scenes(Path(folder)):
            scene = read_scene(path)
            config = Config.from_dict({"scenario": {"lanes": lanes}, "env": {"max_episode_s": horizon_s}})
            seats = seats_of(scene, args.seats, horizon_s)
            road = scene_road(scene.network)
            types = reactive_types(scene, config.scenario.step_length_s).types
            options = run_options(scene_config(config, scene, road).scenario)
            xy_us, to_us = move_costs(scene, config, seats[:10], types)
            costs.append(f"{to_us:.2f} us against {xy_us:.2f} us a call on the {label.split(' (')[0]} scene")
            for reactive in (False, True):
                raw, now, short, simulated = [], [], [], []
                for _ in range(args.rounds):  # alternating, so that a busy spell of the machine hits every measure
                    raw.append(raw_speed(scene, seats[0][1], seats[-1][1] - seats[0][1], options, types,
                                         road.speed_limit_mps))
                    parts, simulated_s = breakdown(scene, config, reactive, seats, types)
                    now.append(parts)
                    simulated.append(simulated_s)
                    with state_resets(Path(folder)):
                        short.append(breakdown(scene, config, reactive, seats, types, STATE_PARTS)[0])
                simulated_s = float(np.median(simulated))
                raw_ms = 1000 * simulated_s / float(np.median(raw))
                now_ms = {part: float(np.median([each[part] for each in now])) for part in SUMO_PARTS}
                short_ms = {part: float(np.median([each[part] for each in short])) for part in SUMO_PARTS}
                short_ms["moves"] *= to_us / xy_us
                floor_ms = sum(short_ms.values())
                mode = "reactive" if reactive else "non-reactive"
                rows.append(f"| {label} | {mode} | {simulated_s:.1f} | {raw_ms:.1f} | {raw_ms / GOAL:.1f} | "
                            + " | ".join(f"{now_ms[part]:.1f}" for part in SUMO_PARTS)
                            + f" | {sum(now_ms.values()):.1f} ({raw_ms / sum(now_ms.values()):.2f}x) | "
                            + " | ".join(f"{short_ms[part]:.1f}" for part in SUMO_PARTS)
                            + f" | **{floor_ms:.1f} ({raw_ms / floor_ms:.2f}x)** |")
                print(rows[-1], flush=True)
    section = f"""
## The floor of a closed-loop episode in a recorded scene (issue 52)

Command: `python benchmarks/bench_replay_floor.py --seats {args.seats} --rounds {args.rounds}` (not in `make bench`).
bench_replay's scenes, seats and keep episodes, per episode [ms] of CPU time, medians of {args.rounds} alternating
rounds; "raw" is raw SUMO's time for the episode's simulated time (bench_replay's raw column), "budget" what the goal of
{GOAL:g}x allows. "SUMO now": SUMO's own parts of the episodes as they run (bench_replay's second table) and their sum,
with no Python at all. "Every shortcut": the same parts with a reset by `simulation.loadState` of the empty road
instead of a fresh load, and the replayed vehicles' moves costed as `moveTo` on the recorded lane instead of
`moveToXY` ({", ".join(costs)}); both change results (docs/replay.md, "Why
0.8x is out of reach"), and neither is taken. The last column is the floor: SUMO's own work alone, every shortcut
taken, and its ratio to raw SUMO, the most a closed-loop episode could reach with no Python at all.

{HEADER}
{chr(10).join(rows)}
"""
    write_section(args.out, "replay_floor", section)


if __name__ == "__main__":
    main()
