"""The README's figures of a replayed scene: in one held-out car's seat, the human's recorded track and the tracks of
other drivers there (non-reactive), as lateral position against distance along the road and distance ahead of the
human against time; an x marks where a driver's episode ended early (a collision).

- the closed loop (the default): BC, RAIL and the constant set-point, in the seat, among those where the human changed
  lanes, where the BC and RAIL of training seed 0 end farthest apart. docs/results commits the tracks' positions and
  times (x_m, y_m, lane_position_m, time_s) only in that seat (`thin_tracks`; the closed-loop table reads none of
  them): the figure is the same from either.
- `--driver POLICY=LABEL` (repeatable) draws those drivers instead, in the seat where the first one's position error
  at 10 s is the median of its errors over the seats (a typical seat, not a chosen one).

    python experiments/plot_scene_tracks.py CLOSED_LOOP.parquet OUT.png
    python experiments/plot_scene_tracks.py EPISODES.parquet OUT.png --driver log_t2_s0/policy_latest=LABEL ...
"""

from __future__ import annotations

from pathlib import Path

import click
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


def median_seat(metrics: pd.DataFrame, policy: str) -> tuple:
    """The seat (scene, vehicle, start) where `policy`'s position error at 10 s (non-reactive) is the median of its
    errors over the seats (the lower middle one of an even count)."""
    errors = metrics[(metrics["policy"] == policy) & (metrics["mode"] == "non-reactive")].dropna(
        subset=["position_error_10s_m"]).sort_values(["position_error_10s_m", *SEAT])
    if errors.empty:
        raise click.UsageError(f"no non-reactive episode of {policy!r} reaches 10 s")
    return tuple(errors.iloc[(len(errors) - 1) // 2][SEAT])


@click.command()
@click.argument("metrics_path", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--driver", "drivers", multiple=True, metavar="POLICY=LABEL",
              help="Draw this driver (repeatable), in the seat of the first one's median 10 s error.")
def main(metrics_path: Path, out: Path, drivers: tuple[str, ...]) -> None:
    tracks, metrics = pd.read_parquet(tracks_path(metrics_path)), pd.read_parquet(metrics_path)
    if drivers:
        colours = ["tab:blue", "tab:red", "tab:green", "tab:gray", "tab:purple"]
        named = dict(driver.split("=", 1) for driver in drivers)
        shown = {HUMAN: DRIVERS[HUMAN], **{policy: (label, colours[k % len(colours)])
                                           for k, (policy, label) in enumerate(named.items())}}
        seat = median_seat(metrics, next(iter(named)))
    else:
        shown, seat = DRIVERS, chosen_seat(tracks)
    chosen = tracks[(tracks["mode"] == "non-reactive") & (tracks[SEAT] == pd.Series(seat, index=SEAT)).all(axis=1)]
    human = chosen[chosen["policy"] == HUMAN].set_index("time_s")
    figure = Figure(figsize=(9, 5.5), layout="constrained")
    above, below = figure.subplots(2, 1)
    for policy, (label, colour) in shown.items():
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
    main()
