"""sumo-rail: imitation learning of highway driving decisions (RAIL) in SUMO.

Importing the package registers the Gymnasium environment `sumo_rail/Highway-v0`; SUMO itself is only
started when an environment is reset. `sumo_rail.parallel_env(egos=K, config=...)` makes the env core, a PettingZoo
environment of K egos on one road (`sumo_rail.sim.parallel_env.ParallelHighwayEnv`); `sumo_rail.HighwayEnv` is its
one-ego Gymnasium adapter (`sumo_rail.sim.env.HighwayEnv`), imported on first use.

The library has one subpackage per stage of the pipeline, each importing only from the stages before it:
the top level (`config`, `seeding`, `datasets`) -> `sim` -> `drivers` -> `runners` -> `evaluation` ->
`learning` -> `report`.
"""

from __future__ import annotations

from importlib.metadata import version
from typing import TYPE_CHECKING, Any

import gymnasium

if TYPE_CHECKING:
    from pathlib import Path

    from sumo_rail.config import Config
    from sumo_rail.sim.parallel_env import ParallelHighwayEnv

__version__ = version("sumo-rail")
ENV_ID = "sumo_rail/Highway-v0"
SCENE_ENV_ID = "sumo_rail/Scene-v0"
"""A recorded scene's env (`sumo_rail.recordings.seat.SceneEnv`): `gymnasium.make(SCENE_ENV_ID, scene=FOLDER)`."""
__all__ = ["ENV_ID", "SCENE_ENV_ID", "HighwayEnv", "__version__", "parallel_env"]

for _id, _entry in ((ENV_ID, "sumo_rail.sim.env:HighwayEnv"), (SCENE_ENV_ID, "sumo_rail.recordings.seat:SceneEnv")):
    if _id not in gymnasium.registry:
        gymnasium.register(id=_id, entry_point=_entry)


def parallel_env(egos: int = 1, config: Config | dict[str, Any] | str | Path | None = None,
                 transport: str = "auto", render_mode: str | None = None) -> ParallelHighwayEnv:
    """A PettingZoo ParallelEnv of `egos` egos (agents ego_0 ... ego_{K-1}) on one SUMO road, each driven as
    `HighwayEnv`'s ego; `config`, `transport` and `render_mode` as `HighwayEnv` takes them (see
    `sumo_rail.sim.parallel_env`)."""
    from sumo_rail.sim.parallel_env import ParallelHighwayEnv

    return ParallelHighwayEnv(egos=egos, config=config, transport=transport, render_mode=render_mode)


def __getattr__(name: str) -> Any:
    """`HighwayEnv` on first use, so importing the package stays cheap."""
    if name == "HighwayEnv":
        from sumo_rail.sim.env import HighwayEnv

        return HighwayEnv
    raise AttributeError(f"module 'sumo_rail' has no attribute {name!r}")
