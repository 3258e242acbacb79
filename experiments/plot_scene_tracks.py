"""The README's figure of a replayed scene: in one held-out car's seat, the human's recorded track and the tracks of
BC, RAIL and the constant set-point driven there (non-reactive), as lateral position against distance along the road
and distance ahead of the human against time; an x marks where a driver's episode ended early (a collision). The seat
is the one, among those where the human changed lanes, where
the BC and RAIL of training seed 0 end farthest apart.

docs/results commits the tracks' positions and times (x_m, y_m, lane_position_m, time_s) only in the seat this figure
shows (`thin_tracks`; the closed-loop table reads none of them): the figure is the same from either.

    python experiments/plot_scene_tracks.py CLOSED_LOOP.parquet OUT.png
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sumo_rail.evaluation.scene_evaluation import HUMAN, tracks_path

DRIVERS = {HUMAN: ("the human (recorded)", "black"), "rail_s0/policy_bc": ("BC", "tab:blue"),
           "rail_s0/policy_latest": ("RAIL", "tab:red"), "keep": ("constant set-point", "tab:gray")}
SEAT = ["scene", "vehicle", "start_s"]


def chosen_seat(tracks: pd.DataFrame) -> tuple:
    """The seat (scene, vehicle, start) where the human changed lanes and BC and RAIL end farthest apart."""
    replayed = tracks[tracks["mode"] == "non-reactive"]
    human = replayed[replayed["policy"] == HUMAN]
    changed = human.groupby(SEAT)["lane"].nunique()
    ends = replayed.groupby(["policy", *SEAT])["lane_position_m"].last()
    apart = {seat: abs(ends.get(("rail_s0/policy_bc", *seat), np.nan) - ends.get(("rail_s0/policy_latest", *seat),
                                                                                 np.nan))
             for seat in changed[changed > 1].index}
    return max((seat for seat in apart if not np.isnan(apart[seat])), key=apart.get)


POSITIONS = ["x_m", "y_m", "lane_position_m", "time_s"]
"""What only this figure reads of the tracks."""


def thin_tracks(tracks: pd.DataFrame) -> pd.DataFrame:
    """The tracks with POSITIONS left empty (null) outside the chosen seat: the same figure and the same closed-loop
    table, from a third of the file."""
    seat = chosen_seat(tracks)
    elsewhere = ~(tracks[SEAT] == pd.Series(seat, index=SEAT)).all(axis=1)
    return tracks.assign(**{name: tracks[name].mask(elsewhere) for name in POSITIONS})


def main(metrics_path: Path, out: Path) -> None:
    tracks, metrics = pd.read_parquet(tracks_path(metrics_path)), pd.read_parquet(metrics_path)
    seat = chosen_seat(tracks)
    chosen = tracks[(tracks["mode"] == "non-reactive") & (tracks[SEAT] == pd.Series(seat, index=SEAT)).all(axis=1)]
    human = chosen[chosen["policy"] == HUMAN].set_index("time_s")
    figure = Figure(figsize=(9, 5.5), layout="constrained")
    above, below = figure.subplots(2, 1)
    for policy, (label, colour) in DRIVERS.items():
        track = chosen[chosen["policy"] == policy]
        if track.empty:
            continue
        style = {"color": colour, "linewidth": 2.5 if policy == HUMAN else 1.5}
        ended = metrics[(metrics["policy"] == policy) & (metrics["mode"] == "non-reactive")
                        & (metrics[SEAT] == pd.Series(seat, index=SEAT)).all(axis=1)]["termination"]
        marker = {"marker": "x", "markevery": [len(track) - 1], "markersize": 9} if (ended == "collision").any() else {}
        above.plot(track["x_m"], track["y_m"], label=label, **style, **marker)
        ahead = track["lane_position_m"].to_numpy() - np.interp(track["time_s"], human.index,
                                                                human["lane_position_m"])
        below.plot(track["time_s"] - seat[2], ahead, **style, **marker)
    above.set_xlabel("x along the road [m]")
    above.set_ylabel("y [m] (lanes)")
    above.legend(loc="best", fontsize=8)
    above.set_title(f"{seat[1]} of {seat[0]}, seated at {seat[2]:g} s; the other cars replayed as recorded "
                    f"(x: a replayed car ran into it)", fontsize=9)
    below.axhline(0.0, color="black", linewidth=0.5)
    below.set_xlabel("time in the seat [s]")
    below.set_ylabel("ahead of the human [m]")
    out.parent.mkdir(parents=True, exist_ok=True)
    FigureCanvasAgg(figure).print_png(str(out))
    print(f"wrote {out}: seat {seat}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
