"""sumo-rail: imitation learning of highway driving decisions (RAIL) in SUMO.

Importing the package registers the Gymnasium environment `sumo_rail/Highway-v0`; SUMO itself is only
started when an environment is reset. `sumo_rail.HighwayEnv` is the environment class
(`sumo_rail.sim.env.HighwayEnv`), imported on first use.

The library has one subpackage per stage of the pipeline, each importing only from the stages before it:
the top level (`config`, `seeding`, `datasets`) -> `sim` -> `drivers` -> `runners` -> `evaluation` ->
`learning` -> `report`.
"""

from importlib.metadata import version
from typing import Any

import gymnasium

__version__ = version("sumo-rail")
ENV_ID = "sumo_rail/Highway-v0"
__all__ = ["ENV_ID", "HighwayEnv", "__version__"]

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="sumo_rail.sim.env:HighwayEnv")


def __getattr__(name: str) -> Any:
    """`HighwayEnv` on first use, so importing the package stays cheap."""
    if name == "HighwayEnv":
        from sumo_rail.sim.env import HighwayEnv

        return HighwayEnv
    raise AttributeError(f"module 'sumo_rail' has no attribute {name!r}")
