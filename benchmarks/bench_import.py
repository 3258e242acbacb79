"""Benchmark: `sumo-rail import-recording` of a synthetic highD-sized recording (about 1,000,000 track rows, 15
minutes at 25 Hz, a few thousand vehicles), its wall time and peak memory. Writes its section of docs/benchmarks.md.

The recording is written to highD's published columns: 3 lanes a direction, vehicles at constant speeds entering
across the 15 minutes, 15% trucks, each seen for about 13 s (highD's median is 13.6 s). The import runs as a user
runs it, in a fresh process: it reads every row of both directions and keeps the lower one.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from doc_section import write_section

from sumo_rail.datasets import sumo_version
from sumo_rail.recordings.highd import RECORDING_META_COLUMNS, TRACKS_COLUMNS, TRACKS_META_COLUMNS

UPPER, LOWER = (8.5, 12.25, 16.0, 19.75), (21.5, 25.25, 29.0, 32.75)
ROAD_M = 420.0


def synthetic_recording(folder: Path, vehicles: int, frames_each: int, seed: int) -> tuple[Path, int]:
    """Write the recording; returns its tracks file and row count."""
    rng = np.random.default_rng(seed)
    total_frames = 15 * 60 * 25
    upper = rng.random(vehicles) < 0.5
    truck = rng.random(vehicles) < 0.15
    length, width = np.where(truck, 12.0, 4.5), np.where(truck, 2.5, 1.8)
    speed = np.where(truck, rng.normal(24.0, 1.5, vehicles), rng.normal(33.0, 4.0, vehicles))
    strip = rng.integers(0, 3, vehicles)
    first = rng.integers(1, total_frames - frames_each, vehicles)
    k = np.arange(frames_each)
    ids = np.repeat(np.arange(1, vehicles + 1), frames_each)
    frame = (first[:, None] + k[None, :]).ravel()
    travelled = (speed[:, None] * k[None, :] / 25.0).ravel()
    sign = np.repeat(np.where(upper, -1.0, 1.0), frames_each)
    x = np.where(sign < 0, ROAD_M - travelled - np.repeat(length, frames_each), travelled)
    markings = np.where(upper[:, None], np.array(UPPER)[None, :], np.array(LOWER)[None, :])
    centre = (markings[np.arange(vehicles), strip] + markings[np.arange(vehicles), strip + 1]) / 2
    lane_id = np.where(upper, 2 + strip, len(UPPER) + 2 + strip)
    tracks = pd.DataFrame(0.0, index=np.arange(len(ids)), columns=list(TRACKS_COLUMNS))
    tracks["frame"], tracks["id"], tracks["x"] = frame, ids, x
    tracks["y"] = np.repeat(centre - width / 2, frames_each)
    tracks["width"], tracks["height"] = np.repeat(length, frames_each), np.repeat(width, frames_each)
    tracks["xVelocity"] = sign * np.repeat(speed, frames_each)
    tracks["laneId"] = np.repeat(lane_id, frames_each)
    tracks[[c for c in TRACKS_COLUMNS if c.endswith("Id") and c != "laneId"]] = 0
    tracks.to_csv(folder / "01_tracks.csv", index=False, float_format="%.2f")
    meta = pd.DataFrame(0, index=np.arange(vehicles), columns=list(TRACKS_META_COLUMNS))
    meta["id"], meta["width"], meta["height"] = np.arange(1, vehicles + 1), length, width
    meta["initialFrame"], meta["finalFrame"], meta["numFrames"] = first, first + frames_each - 1, frames_each
    meta["class"], meta["drivingDirection"] = np.where(truck, "Truck", "Car"), np.where(upper, 1, 2)
    meta.to_csv(folder / "01_tracksMeta.csv", index=False)
    recording = dict.fromkeys(RECORDING_META_COLUMNS, 0)
    recording.update(id=1, frameRate=25, upperLaneMarkings=";".join(map(str, UPPER)),
                     lowerLaneMarkings=";".join(map(str, LOWER)))
    pd.DataFrame([recording]).to_csv(folder / "01_recordingMeta.csv", index=False)
    return folder / "01_tracks.csv", len(tracks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--vehicles", type=int, default=3000)
    parser.add_argument("--frames-each", type=int, default=334, help="frames per vehicle (334 = 13.4 s)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tracks, rows = synthetic_recording(Path(folder), args.vehicles, args.frames_each, seed=0)
        size_mb = tracks.stat().st_size / 1e6
        command = [sys.executable, "-m", "sumo_rail_cli", "import-recording", "--format", "highd", str(tracks),
                   "--out", str(Path(folder) / "scene")]
        start = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True, check=False)
        seconds = time.perf_counter() - start
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        if result.returncode != 0:
            raise SystemExit(f"the import failed: {result.stderr or result.stdout}")
    summary = " / ".join(line for line in result.stdout.splitlines() if line.startswith(("kept", "split")))
    section = f"""
## Importing a highD-sized recording (issue 46)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()}.
A synthetic highD recording written to the published columns: {rows:,} track rows ({size_mb:.0f} MB of CSV),
{args.vehicles} vehicles over 15 minutes at 25 Hz, both directions, 3 lanes each. `sumo-rail import-recording
--format highd 01_tracks.csv --out scene` in a fresh process reads every row, keeps the lower direction, builds its
road with netconvert and writes the scene folder: {summary}.

| wall time [s] | peak memory [MB] |
|---|---|
| {seconds:.1f} | {peak_mb:.0f} |

Goal: at most 60 s and 2 GB on 2 cores.
"""
    write_section(args.out, "import", section)


if __name__ == "__main__":
    main()
