"""Recorded driving (highD, NGSIM, SUMO FCD) as scenes: read, written, replayed in SUMO and read as demonstrations.

May import: the top level, sim, drivers and runners (a scene is replayed in the env's own simulation, driven by
the project's drivers, many seats at once on the runners' backends).
"""
