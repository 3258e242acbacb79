"""The sumo-rail command line (installed as package sumo_rail_cli)."""
