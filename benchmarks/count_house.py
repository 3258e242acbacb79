"""Counts for docs/design.md's "The house in numbers" (issue 52): the classes on the way from `evaluate-scene
--policy` to the seat, and the private members of sumo_rail/sim/ touched outside it.

The way to the seat: one `EvaluationTask` in a seat (evaluate-scene's unit of work; a `--policy` driver's reset is
any driver's) in a small scene of SUMO's drivers; when SUMO is loaded for the seat, every class with a method on the
call stack from the task down to the load (the class that defines the method and, where another, the instance's). The
private members: `tests/test_layout.py`'s SUMO-boundary check over the tree `--root` (default this one): each (file,
member) it finds.
Usage: `python benchmarks/count_house.py [--root TREE]` (the classes are those of the sumo_rail that Python imports).
"""

from __future__ import annotations

import argparse
import importlib.util
import inspect
import os
import tempfile
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def layout_check() -> ModuleType:
    """tests/test_layout.py, whose SUMO-boundary check this counts with."""
    spec = importlib.util.spec_from_file_location("test_layout", ROOT / "tests" / "test_layout.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def private_members(root: Path) -> list[tuple[str, str]]:
    """(file, private member of sim) for each one touched, imported or overridden outside sim/ in `root`."""
    layout = layout_check()
    private = layout.sim_private_names(root)
    found = {(line.split(":")[0], line.split()[-1].rsplit(".", 1)[-1])
             for path in layout.boundary_scope(root) for line in layout.boundary_breaches(path, private, root)}
    return sorted((where, member) for where, member in found if member.startswith("_"))


def seat_path() -> list[str]:
    """The classes on the call stack from an EvaluationTask in a seat to SUMO's load of the seat, outermost first."""
    import pandas as pd

    from sumo_rail.config import Config
    from sumo_rail.evaluation.protocol import EvaluationTask
    from sumo_rail.evaluation.scene_evaluation import RecordedSeatStart
    from sumo_rail.recordings.seats import Seat
    from sumo_rail.recordings.sumo_drivers import SumoDriversSettings, record_sumo_drivers
    from sumo_rail.runners.backends import WorkerContext
    from sumo_rail.runners.rollout import KeepDriver
    from sumo_rail.sim import simulation

    folder = Path(tempfile.mkdtemp()) / "scene"
    record_sumo_drivers(SumoDriversSettings(out=folder, seed=4, duration_s=30.0), Config.from_dict(
        {"scenario": {"length_m": 1000.0, "lanes": 3, "flow_veh_per_h": 3000.0, "warmup_s": 30.0}}))
    tracks = pd.read_parquet(folder / "tracks.parquet")
    vehicle = str(tracks["vehicle_id"].iloc[len(tracks) // 2])
    start_s = float(tracks.loc[tracks["vehicle_id"] == vehicle, "time_s"].iloc[0]) + 1.0
    paths: list[list[str]] = []
    load = simulation.Simulation._load  # noqa: SLF001 - counting its calls

    def watched_load(self: simulation.Simulation, extra: list[str]) -> None:
        classes, here = [type(self).__name__, "Simulation"], inspect.currentframe()  # innermost first
        frame = here.f_back if here is not None else None
        while frame is not None:
            owner, qualname = frame.f_locals.get("self"), frame.f_code.co_qualname
            if owner is not None and "." in qualname:
                classes += [type(owner).__name__, qualname.split(".")[0]]
            if qualname == "EvaluationTask.run":
                break
            frame = frame.f_back
        paths.append(list(dict.fromkeys(reversed(classes))))
        load(self, extra)

    simulation.Simulation._load = watched_load  # type: ignore[method-assign]  # noqa: SLF001 - counting its calls
    config = Config.from_dict({"scenario": {"speed_limit_mps": 44.44},
                               "env": {"max_episode_s": 2.0, "v_max_mps": 44.44}})
    context = WorkerContext()
    try:
        seat = Seat(str(folder), vehicle, start_s)
        EvaluationTask(RecordedSeatStart(config, seat, False), KeepDriver(), 0).run(context)
    finally:
        context.close()
    return paths[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--root", type=Path, default=ROOT, help="the tree whose private-member use is counted")
    args = parser.parse_args()
    os.environ.setdefault("SUMO_RAIL_CACHE", tempfile.mkdtemp())
    path = seat_path()
    print(f"classes on the way from evaluate-scene --policy to the seat: {len(path)} ({', '.join(path)})")
    members = private_members(args.root.resolve())
    print(f"private members of sim/ touched outside it: {len(members)} (file, member) pairs, "
          f"{len({member for _, member in members})} members")
    for where, member in members:
        print(f"  {where}: {member}")


if __name__ == "__main__":
    main()
