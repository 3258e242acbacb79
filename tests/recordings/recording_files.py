"""Small recordings written by hand to each format's documented headers and conventions (no download in tests).

highD: image coordinates in metres, y down, (x, y) the top-left corner of the box, width along x; upper direction
(drivingDirection 1) driven leftwards, lanes 2, 3 between the upper markings from the top; lower direction
(drivingDirection 2) driven rightwards, lanes 5, 6 between the lower markings. NGSIM: feet, ft/s, 10 Hz, Lane_ID 1
the leftmost, Local_Y the front along the road, Local_X the lateral centre from the left edge.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from sumo_rail.recordings.highd import RECORDING_META_COLUMNS, TRACKS_COLUMNS, TRACKS_META_COLUMNS
from sumo_rail.recordings.ngsim import COLUMNS as NGSIM_COLUMNS

UPPER_MARKINGS = (2.0, 5.5, 9.0)
LOWER_MARKINGS = (11.0, 14.5, 18.25)
"""Lower lanes: 5 (11.0 to 14.5, the leftmost, by the median) and 6 (14.5 to 18.25, the rightmost)."""


def highd_vehicle(vehicle: int, frames: range, x0: float, lane_id: int, upper: bool, speed: float = 30.0,
                  length: float = 4.5, width: float = 1.8, y_offset: float = 0.0) -> list[dict]:
    """Rows of one highD vehicle at constant speed [m/s] in lane `lane_id`, its box centred in the lane."""
    markings = UPPER_MARKINGS if upper else LOWER_MARKINGS
    first = 2 if upper else len(UPPER_MARKINGS) + 2
    centre = (markings[lane_id - first] + markings[lane_id - first + 1]) / 2 + y_offset
    sign = -1.0 if upper else 1.0
    rows = []
    for k, frame in enumerate(frames):
        row = dict.fromkeys(TRACKS_COLUMNS, 0)
        row.update(frame=frame, id=vehicle, x=x0 + sign * speed * k / 25.0, y=centre - width / 2, width=length,
                   height=width, xVelocity=sign * speed, yVelocity=0.0, xAcceleration=0.0, yAcceleration=0.0,
                   laneId=lane_id, frontSightDistance=100.0, backSightDistance=100.0)
        rows.append(row)
    return rows


def write_highd(folder: Path, rows: list[dict], classes: dict[int, str] | None = None, stem: str = "01",
                meta_rows: list[dict] | None = None) -> Path:
    """Write a highD recording (tracks, tracksMeta, recordingMeta) of `rows`; returns the tracks file."""
    tracks = pd.DataFrame(rows, columns=list(TRACKS_COLUMNS))
    if meta_rows is None:
        meta_rows = []
        for vehicle, track in tracks.groupby("id"):
            row = dict.fromkeys(TRACKS_META_COLUMNS, 0)
            row.update(id=vehicle, width=track["width"].iloc[0], height=track["height"].iloc[0],
                       initialFrame=track["frame"].min(), finalFrame=track["frame"].max(), numFrames=len(track),
                       drivingDirection=1 if track["xVelocity"].iloc[0] < 0 else 2,
                       **{"class": (classes or {}).get(int(vehicle), "Car")})
            meta_rows.append(row)
    recording = dict.fromkeys(RECORDING_META_COLUMNS, 0)
    recording.update(id=1, frameRate=25, upperLaneMarkings=";".join(map(str, UPPER_MARKINGS)),
                     lowerLaneMarkings=";".join(map(str, LOWER_MARKINGS)))
    tracks.to_csv(folder / f"{stem}_tracks.csv", index=False)
    pd.DataFrame(meta_rows, columns=list(TRACKS_META_COLUMNS)).to_csv(folder / f"{stem}_tracksMeta.csv", index=False)
    pd.DataFrame([recording]).to_csv(folder / f"{stem}_recordingMeta.csv", index=False)
    return folder / f"{stem}_tracks.csv"


def ngsim_vehicle(vehicle: int, frames: range, local_y_ft: float, lane_id: int, speed_ftps: float = 50.0,
                  length_ft: float = 15.0, width_ft: float = 6.0, v_class: int = 2,
                  total_frames: int | None = None) -> list[dict]:
    """Rows of one NGSIM vehicle at constant speed [ft/s] in lane `lane_id` (12 ft lanes, centred)."""
    rows = []
    for k, frame in enumerate(frames):
        y = local_y_ft + speed_ftps * k / 10.0
        rows.append({"Vehicle_ID": vehicle, "Frame_ID": frame, "Total_Frames": total_frames or len(frames),
                     "Global_Time": 1118846979700 + frame * 100, "Local_X": 12.0 * lane_id - 6.0, "Local_Y": y,
                     "Global_X": 6451000.0, "Global_Y": 1873000.0 + y, "v_Length": length_ft, "v_Width": width_ft,
                     "v_Class": v_class, "v_Vel": speed_ftps, "v_Acc": 0.0, "Lane_ID": lane_id, "Preceding": 0,
                     "Following": 0, "Space_Headway": 0.0, "Time_Headway": 0.0})
    return rows


def write_ngsim(path: Path, rows: list[dict]) -> Path:
    """Write an NGSIM trajectory CSV of `rows` with the published header."""
    pd.DataFrame(rows, columns=list(NGSIM_COLUMNS)).to_csv(path, index=False)
    return path


def fcd_vehicle(vehicle: str, steps: range, front_m: float, y_m: float, lane: str, speed: float = 20.0,
                step_s: float = 0.1) -> list[dict]:
    """FCD rows of one vehicle at constant speed [m/s] along +x (pos equals x, as on a built road)."""
    return [{"time": k * step_s, "id": vehicle, "x": front_m + speed * (k - steps[0]) * step_s, "y": y_m,
             "speed": speed, "lane": lane} for k in steps]


def write_fcd(path: Path, rows: list[dict]) -> Path:
    """Write SUMO FCD output of `rows` (time, id, x, y, speed, lane; pos = x and type car unless given, angle 90)."""
    steps: dict[float, list[str]] = {}
    for row in rows:
        steps.setdefault(round(row["time"], 6), []).append(
            f'<vehicle id="{row["id"]}" x="{row["x"]:.2f}" y="{row["y"]:.2f}" angle="90.00" '
            f'type="{row.get("type", "car")}" '
            f'speed="{row["speed"]:.2f}" pos="{row.get("pos", row["x"]):.2f}" lane="{row["lane"]}"/>')
    path.write_text("<fcd-export>" + "".join(f'<timestep time="{time:.2f}">{"".join(vehicles)}</timestep>'
                                             for time, vehicles in sorted(steps.items())) + "</fcd-export>")
    return path


def lane_y(lanes: int, lane: int, width: float = 3.2) -> float:
    """The centre y [m] of lane `lane` (0 the rightmost) of `build_road`'s road of `lanes` lanes of `width`."""
    return -(lanes - lane - 0.5) * width


SCENE_SPEED = ("--set", "scenario.speed_limit_mps=44.44", "--set", "env.v_max_mps=44.44")
"""The settings of a scene whose road is built from a recording (its limit `road.ROAD_SPEED_MPS`), which commands on
the scene require."""
SCENE_SPEED_CONFIG = {"scenario": {"speed_limit_mps": 44.44}, "env": {"v_max_mps": 44.44}}
