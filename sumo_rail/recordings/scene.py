"""The scene: the contract between the recording readers/writers and everything that replays or learns from them.

A scene is one driving direction of a recording on one road: every vehicle's track as rows of `TRACK_COLUMNS`
(one row per vehicle per frame, SI units) and a `SceneMeta`. Positions are in the coordinates of the scene's SUMO
network (`road.net.xml` in the scene folder, or the user's network for FCD), at the centre of the vehicle's front
bumper (SUMO's own convention, so `moveToXY` takes them as they are); `lane` is SUMO's lane index on the vehicle's
edge (0 = the rightmost lane in the driving direction). A scene folder holds `tracks.parquet`, `scene.json`
(the `SceneMeta`), `road.net.xml` when the road was built from the recording, and `split.parquet`
(vehicle_id -> "train" | "validation" | "test").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pyarrow as pa

TRACK_SCHEMA = pa.schema([
    ("vehicle_id", pa.string()),        # unique in the scene (a reused id in the source is split: "17", "17#2")
    ("time_s", pa.float64()),           # [s] from the start of the recording
    ("x_m", pa.float64()),              # [m] network x of the front bumper's centre
    ("y_m", pa.float64()),              # [m] network y of the front bumper's centre
    ("heading_deg", pa.float64()),      # [deg] SUMO's angle: 0 = north, clockwise (90 = east)
    ("speed_mps", pa.float64()),        # [m/s] along the heading
    ("acceleration_mps2", pa.float64()),  # [m/s^2] along the heading
    ("edge", pa.string()),              # SUMO edge id of the network the vehicle is on
    ("lane", pa.int16()),               # SUMO lane index on that edge, 0 = rightmost
    ("lane_position_m", pa.float64()),  # [m] position of the front bumper along the lane
    ("length_m", pa.float32()),         # [m] vehicle length
    ("width_m", pa.float32()),          # [m] vehicle width
    ("vehicle_class", pa.string()),     # SUMO vehicle class: "passenger" or "truck" (buses read as truck)
])
TRACK_COLUMNS = tuple(TRACK_SCHEMA.names)


@dataclass(frozen=True)
class SceneMeta:
    """What a scene is and where it came from (stored as scene.json)."""

    format: str
    """Source format: "highd", "ngsim", "fcd" or "sumo" (tracks taken from a SUMO run directly)."""
    frame_rate_hz: float
    """Frames per second of the tracks [Hz] (highD 25, NGSIM 10, FCD 1 / --step-length)."""
    network: str
    """The SUMO network the positions refer to: "road.net.xml" (in the scene folder) or an absolute path."""
    lanes: int
    """Lanes of the modelled road in the scene's driving direction."""
    direction: str = ""
    """The recording's driving direction kept (highD: "upper" / "lower"; NGSIM and FCD: "")."""
    sources: dict[str, str] = field(default_factory=dict)
    """Each source file's absolute path -> sha256 of its bytes."""
    dropped: dict[str, str] = field(default_factory=dict)
    """Each dropped track's source id -> the one-phrase reason (too short, off the modelled lanes, gap in frames)."""
    settings: dict[str, object] = field(default_factory=dict)
    """The import's settings (section, vehicles, minimum track length ...), for provenance."""
