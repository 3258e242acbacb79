"""Plain-XML sources of the sumo-rail highway, shipped as package data (see network.py)."""
