"""`python -m sumo_rail_cli`: the same as the `sumo-rail` command."""

from .main import cli

cli(prog_name="sumo-rail")
