"""Recorded driving (highD, NGSIM, SUMO FCD) as scenes: read, written, replayed in SUMO and read as demonstrations."""
