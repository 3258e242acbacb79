"""sumo-rail: imitation learning of highway driving decisions (RAIL) in SUMO.

Importing the package registers the Gymnasium environment `sumo_rail/Highway-v0`; SUMO itself is only
started when an environment is reset.
"""

from importlib.metadata import version

import gymnasium

__version__ = version("sumo-rail")
ENV_ID = "sumo_rail/Highway-v0"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="sumo_rail.env:HighwayEnv")
