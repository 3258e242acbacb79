"""Benchmark: a closed-loop episode in a recorded scene (`evaluate-scene`'s episode: the ego in a recorded car's seat,
deciding every 0.5 s through the env, the others replayed or reactive) against raw SUMO stepping of the same scene
(the same vehicles, each departing at its first recorded time, lane, position and speed from a route file, driven
by SUMO alone: libsumo's `simulationStep` and nothing else, with the SUMO options every episode runs with:
`simulation.run_options`, whose continuous lane changes, `--lanechange.duration`, cost SUMO about twice the work
of its default instant ones on the 3 km scene; SUMO's defaults are measured too). Writes its section of
docs/benchmarks.md.

Two scenes: a synthetic highD-sized recording (bench_import's: 3,000 vehicles over 15 minutes at 25 Hz, about
1,000,000 rows, imported as a user does) and a record-sumo-drivers scene (5 lanes, 3 km, 600 s, about 150 vehicles
on the road at once). Speed is simulated seconds per wall-clock second, the ego's episodes' resets (a fresh load of
the road and the first placement) included; time is the process's CPU time (libsumo runs in it), so that other
jobs on a shared machine do not count. A second run of the same episodes times libsumo's calls by part (`SUMO_PARTS`:
the loads, SUMO's steps, the replayed vehicles' moves and entries): where an episode's time goes beyond raw SUMO's.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import platform
import tempfile
import time
import xml.etree.ElementTree as ElementTree
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import libsumo
import numpy as np
from bench_import import synthetic_recording
from doc_section import write_section
from libsumo import _libsumo as compiled

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.recordings.importing import ImportSettings, check_import, import_recording
from sumo_rail.recordings.scene import Scene, read_scene
from sumo_rail.recordings.scene_drivers import reactive_types
from sumo_rail.recordings.scene_observations import scene_road
from sumo_rail.recordings.seat import SceneEnv, scene_config
from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, record_sumo_drivers
from sumo_rail.sim import network
from sumo_rail.sim.replay import DEFAULT_TYPE, VehicleTypes
from sumo_rail.sim.simulation import run_options

LEAD_S = 1.0
"""The ego takes a seat this long into the car's track [s]."""
GOAL = 0.8
"""The speed a closed-loop episode should reach, as a multiple of raw SUMO's."""


def raw_speed(scene: Scene, begin_s: float, seconds: float, options: list[str], types: VehicleTypes | None = None,
              limit_mps: float = 0.0) -> float:
    """Simulated seconds per CPU second of SUMO alone driving the scene's vehicles from `begin_s` for `seconds`
    with SUMO options `options` (the step length among them); with `types`, each vehicle of its type and desired speed
    as in the reactive episodes (the fastest its track records, on a road of limit `limit_mps` [m/s])."""
    routes = ElementTree.Element("routes")
    for type_id, attributes in (types.definitions if types else {}).items():
        ElementTree.SubElement(routes, "vType", attrib={**attributes, "id": type_id})
    edge = str(scene.tracks["edge"].iloc[0])
    ElementTree.SubElement(routes, "route", id="r", edges=edge)
    first = scene.tracks.sort_values("time_s").groupby("vehicle_id", sort=False).first().sort_values("time_s")
    top = scene.tracks.groupby("vehicle_id")["speed_mps"].max()
    for vehicle, row in first.iterrows():
        driver = {"type": types.of_vehicle.get(str(vehicle), DEFAULT_TYPE),
                  "speedFactor": f"{top[vehicle] / limit_mps:.4f}"} if types else {}
        ElementTree.SubElement(routes, "vehicle", id=str(vehicle), route="r", depart=f"{row['time_s']:.2f}",
                               departLane=str(int(row["lane"])), departPos=f"{max(row['lane_position_m'], 0):.2f}",
                               departSpeed=f"{row['speed_mps']:.2f}", length=f"{row['length_m']:.2f}", **driver)
    route_file = scene.folder / "bench.rou.xml"
    ElementTree.ElementTree(routes).write(route_file)
    libsumo.start([network.sumo_binary("sumo"), "-n", str(scene.network), "-r", str(route_file), *options])
    step_s = float(options[options.index("--step-length") + 1])
    try:
        libsumo.simulationStep(begin_s)
        start = time.process_time()
        for _ in range(round(seconds / step_s)):
            libsumo.simulationStep()
        return seconds / (time.process_time() - start)
    finally:
        libsumo.close()


def closed_loop(scene: Scene, config: Config, reactive: bool, seats: list[tuple[str, float]],
                types: VehicleTypes, timed: Counter[str] | None = None,
                parts: Mapping[str, tuple[str, ...]] | None = None) -> tuple[float, float]:
    """(simulated seconds, CPU seconds) of always-keep episodes in `seats` (vehicle, start [s]), the reactive
    vehicles of `types`; with `timed`, libsumo's calls of `parts` (default `SUMO_PARTS`) timed into it by part (CPU
    [s])."""
    parts = SUMO_PARTS if parts is None else parts
    with timed_calls(timed, parts) if timed is not None else contextlib.nullcontext():
        env = SceneEnv(config, scene, reactive=reactive, transport="libsumo", types=types)
        try:
            env.reset(seed=0, options={"vehicle": seats[0][0], "start_s": seats[0][1]})  # SUMO started, not timed
            for part in parts if timed is not None else ():
                timed[part] = timed[part + " calls"] = 0
            simulated, start = 0.0, time.process_time()
            for vehicle, start_s in seats:
                env.reset(seed=0, options={"vehicle": vehicle, "start_s": start_s})
                done, info = False, {}
                while not done:
                    _, _, terminated, truncated, info = env.step(0)
                    done = terminated or truncated
                simulated += info["time_s"]
            return simulated, time.process_time() - start
        finally:
            env.close()


SUMO_PARTS = {"load": ("simulation_load",), "steps": ("simulation_step",), "moves": ("vehicle_moveToXY",),
              "entries": ("vehicle_add", "vehicle_setLength", "vehicle_setWidth", "vehicle_setSpeedMode",
                          "vehicle_setLaneChangeMode")}
"""The parts of an episode's SUMO work the breakdown times, by the compiled libsumo functions that do them (the ones
its Python wrappers and the simulation's `DecisionCalls` call): the load of a reset, SUMO's steps, the replayed
vehicles' moves and their entries (added, sized, given to TraCI)."""


@contextlib.contextmanager
def timed_calls(timed: Counter[str], parts: Mapping[str, tuple[str, ...]] = SUMO_PARTS) -> Iterator[None]:
    """Within the block, libsumo's calls of `parts` (a simulation made in the block calls the timed ones) add
    their CPU time [s] to `timed[part]` and count themselves in `timed[part + " calls"]`; `timed["timer inside"]` is
    the timing's own cost inside a call's time (from 100,000 timed empty calls)."""
    clock = time.process_time

    def timer(call: Callable[..., Any], part: str) -> Callable[..., Any]:
        def timed_call(*args: Any, **kwargs: Any) -> Any:
            begin = clock()
            try:
                return call(*args, **kwargs)
            finally:
                timed[part] += clock() - begin
                timed[part + " calls"] += 1
        return timed_call

    empty, count = timer(lambda: None, "timer inside"), 100_000
    for _ in range(count):
        empty()
    timed["timer inside"] /= count
    del timed["timer inside calls"]
    replaced = {name: getattr(compiled, name) for names in parts.values() for name in names}
    for part, names in parts.items():
        for name in names:
            setattr(compiled, name, timer(replaced[name], part))
    try:
        yield
    finally:
        for name, call in replaced.items():
            setattr(compiled, name, call)


def breakdown(scene: Scene, config: Config, reactive: bool, seats: list[tuple[str, float]],
              types: VehicleTypes, parts: Mapping[str, tuple[str, ...]] = SUMO_PARTS,
              ) -> tuple[dict[str, float], float]:
    """CPU time [ms] per episode of `closed_loop`'s episodes in each part of `parts` (the timing's cost inside
    each call taken out; what is left of it makes a part an upper bound), and the simulated time [s] per episode."""
    timed: Counter[str] = Counter()
    simulated, _ = closed_loop(scene, config, reactive, seats, types, timed, parts)
    return ({part: 1000 * (timed[part] - timed[part + " calls"] * timed["timer inside"]) / len(seats)
             for part in parts}, simulated / len(seats))


def seats_of(scene: Scene, count: int, horizon_s: float) -> list[tuple[str, float]]:
    """`count` cars whose tracks last `LEAD_S` + `horizon_s`, seated `LEAD_S` in, spread over the recording."""
    spans = scene.tracks.groupby("vehicle_id").agg(begin=("time_s", "min"), end=("time_s", "max"),
                                                   kind=("vehicle_class", "first"))
    fit = spans[(spans["end"] - spans["begin"] >= horizon_s + LEAD_S) & (spans["kind"] == "passenger")]
    fit = fit.sort_values("begin").iloc[np.linspace(0, len(fit) - 1, count).astype(int)]
    return [(str(vehicle), float(begin) + LEAD_S) for vehicle, begin in fit["begin"].items()]


def bench_scenes(folder: Path) -> tuple[tuple[str, Path, int, float], ...]:
    """The two scenes, made in `folder`: (label, scene folder, lanes, episode horizon [s]) each."""
    tracks, _ = synthetic_recording(folder, 3000, 334, seed=0)
    highd = ImportSettings("highd", (tracks,), folder / "highd")
    import_recording(highd, Config(), check_import(highd))
    recorded = folder / "drivers"
    record_sumo_drivers(SumoDriversSettings(out=recorded, seed=1), Config.from_dict({"scenario": {"warmup_s": 120.0}}))
    return (("synthetic highD (3 lanes, 420 m, 25 Hz)", highd.out, 3, 10.0),
            ("record-sumo-drivers (5 lanes, 3 km, 10 Hz)", recorded, 5, 15.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seats", type=int, default=30, help="episodes per scene and mode")
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds of every measure (medians)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    rows, drivers, parts, verdicts = [], [], [], []
    with tempfile.TemporaryDirectory() as folder:
        for label, path, lanes, horizon_s in bench_scenes(Path(folder)):
            scene = read_scene(path)
            config = Config.from_dict({"scenario": {"lanes": lanes}, "env": {"max_episode_s": horizon_s}})
            seats = seats_of(scene, args.seats, horizon_s)
            window_s = seats[-1][1] - seats[0][1]
            defaults = ["--step-length", repr(config.scenario.step_length_s), "--no-step-log", "true", "--no-warnings",
                    "true"]
            road = scene_road(scene.network)
            types = reactive_types(scene, config.scenario.step_length_s)
            options = run_options(scene_config(config, scene, road).scenario)
            measured: dict[str, list[float]] = {"raw": [], "defaults": [], "non-reactive": [], "reactive": []}
            for _ in range(args.rounds):  # alternating, so that a busy spell of the machine hits every measure
                measured["raw"].append(raw_speed(scene, seats[0][1], window_s, options, types.types,
                                                 road.speed_limit_mps))
                measured["defaults"].append(raw_speed(scene, seats[0][1], window_s, defaults))
                for reactive in (False, True):
                    simulated, cpu = closed_loop(scene, config, reactive, seats, types.types)
                    measured["reactive" if reactive else "non-reactive"].append(simulated / cpu)
            raw, raw_default, *speeds = (float(np.median(values)) for values in measured.values())
            on_road = scene.tracks.groupby("time_s").size().median()
            drivers.append(f"- {label}: {types.describe().splitlines()[0]}")
            cells = " | ".join(f"{speed:.0f} ({speed / raw:.2f}x; {speed / raw_default:.2f}x)" for speed in speeds)
            rows.append(f"| {label} | {horizon_s:g} | {on_road:.0f} | {raw:.0f} | {raw_default:.0f} | {cells} |")
            for reactive, speed in zip((False, True), speeds, strict=True):
                mode = "reactive" if reactive else "non-reactive"
                verdicts.append(f"{label.split(' (')[0]}, {mode}: {speed / raw:.2f}x, "
                                + ("reached" if speed >= GOAL * raw else "not reached"))
                ms, simulated_s = breakdown(scene, config, reactive, seats, types.types)
                episode_ms = 1000 * simulated_s / speed
                shares = " | ".join(f"{ms[part]:.1f}" for part in SUMO_PARTS)
                parts.append(f"| {label} | {mode} | {simulated_s:.1f} | {1000 * simulated_s / raw:.1f} | "
                             f"{1000 * simulated_s / (GOAL * raw):.1f} | {episode_ms:.1f} | {shares} | "
                             f"{episode_ms - sum(ms.values()):.1f} |")
    load = os.getloadavg()[0]
    section = f"""
## Closed-loop episodes in a recorded scene (issue 46)

Command: `make bench` (runs `python benchmarks/bench_replay.py --seats {args.seats} --rounds {args.rounds}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()}; load
average {load:.1f} at the end of the run (other jobs shared the machine when above 1).
Simulated seconds per CPU second of the process (libsumo runs in it), medians of {args.rounds} alternating rounds
of every measure. Raw SUMO: the scene's vehicles departing from a
route file at their first recorded state, driven by SUMO alone (`simulationStep` only) over the seats' time span,
with the SUMO options every episode runs with (`simulation.run_options`: continuous lane changes over
`scenario.lane_change_duration_s`, collision checks) and the reactive episodes' drivers (each vehicle's vType and
desired speed, `scene_drivers.reactive_types`); and, for comparison, as this benchmark first defined it: SUMO's
default options (instant lane changes, about half the work on the 3 km scene) and default type. Closed loop:
{args.seats} always-keep episodes in seats spread over the recording ({LEAD_S:g} s into each car's track), through
`SceneEnv` (a decision every 0.5 s: observation, command, safety readings), resets (a fresh load of the road, the
first placement) included; non-reactive places every recorded vehicle within 500 m of the ego with `moveToXY` at
every 0.1 s step, reactive places each once and drives it as `evaluate-scene` does. Ratios: to raw SUMO with the
episodes' options and drivers; to raw SUMO as first defined.

{chr(10).join(drivers)}

| scene | episode [s] | vehicles (median) | raw SUMO [sim s / CPU s] | raw, defaults | non-reactive | reactive |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}

Goal: a closed-loop episode at least {GOAL:g}x raw SUMO stepping of the same scene: {"; ".join(verdicts)}.

Where an episode's CPU time goes, per episode [ms]: the episode (the run above), and in a second run of the same
episodes with libsumo's calls timed (the timing's cost inside each call taken out; what is left of it makes these
upper bounds): the load of each reset (SUMO reads its options, network and routes files afresh: a fixed cost of
SUMO's, whatever the files' size), SUMO's steps, the replayed vehicles' moves (`moveToXY`:
SUMO maps each vehicle's recorded x, y onto its lane), their entries (`add`, length and width, speed and lane-change
modes), and the rest, the episode less these (the env's decisions, observation, safety readings, and the replay's own
Python; a lower bound). Raw SUMO
would take the "raw" column for the episode's simulated time; the goal allows the "budget" column.

| scene | mode | simulated [s] | raw [ms] | budget [ms] | episode [ms] | load | steps | moves | entries | rest |
|---|---|---|---|---|---|---|---|---|---|---|
{chr(10).join(parts)}
"""
    write_section(args.out, "replay", section)


if __name__ == "__main__":
    main()
