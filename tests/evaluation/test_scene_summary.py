"""The closed-loop human-likeness tables: methods and their differences paired seat by seat, distributions against
the humans of the same mode."""

from __future__ import annotations

import numpy as np
import pandas as pd

from sumo_rail.evaluation.scene_evaluation import HUMAN
from sumo_rail.evaluation.scene_summary import SEAT_KEYS, distribution_table, track_table


def seat_rows(errors_m: np.ndarray, policy: str) -> pd.DataFrame:
    """Metrics rows of 16 seats: vehicles v0 .. v3 of scenes a and b, each taken at 1 s and at 2 s, in that order."""
    seats = pd.MultiIndex.from_product([["a", "b"], [f"v{k}" for k in range(4)], [1.0, 2.0]],
                                       names=["scene", "vehicle", "start_s"]).to_frame(index=False)
    return seats.assign(policy=policy, mode="reactive", collisions=0, at_fault_collisions=0, stopped=False,
                        progress_ratio=1.0, lane_changes=0, distance_m=400.0, hard_braking=0,
                        ttc_below_1_5s_share=0.0, steps=30, driving_score=1.0, position_error_1s_m=1.0,
                        position_error_5s_m=5.0, position_error_10s_m=errors_m)


def test_runs_are_paired_on_the_whole_seat_not_on_the_vehicle_alone():
    """One vehicle id is four seats (two scenes, two start times) with very different errors: pairing the two methods'
    rows by vehicle only would mix them; paired on (mode, scene, vehicle, start_s), the spread cancels."""
    errors = np.random.default_rng(0).uniform(10.0, 60.0, 16)
    bc, rail = seat_rows(errors, "bc"), seat_rows(errors + 3.0, "rail")
    metrics = pd.concat([bc, rail.iloc[::-1]], ignore_index=True)  # the two runs' rows in opposite orders
    assert rail.duplicated("vehicle").any() and not rail.duplicated(SEAT_KEYS).any()
    table = track_table(metrics, {"BC": ["bc"], "RAIL": ["rail"]}, [("RAIL", "BC")])
    row = next(line for line in table.splitlines() if line.startswith("| RAIL - BC"))
    assert "+3.00 [+3.00, +3.00] *" in row


def decision_rows(policy: str, mode: str, seat: int, speeds_mps: np.ndarray) -> pd.DataFrame:
    return pd.DataFrame({"policy": policy, "mode": mode, "scene": "a", "vehicle": f"v{seat}", "start_s": 1.0,
                         "speed_mps": speeds_mps, "lane": 1, "gap_m": 30.0 + speeds_mps})


def test_each_mode_is_measured_against_its_own_episodes_only():
    """The driver drives as the humans in the non-reactive mode and 10 m/s faster in the reactive one: the distances
    are 0 and 10 m/s, and each mode's row is the one its own tracks alone give (nothing pooled over the modes)."""
    rng = np.random.default_rng(1)
    humans = [20.0 + 10.0 * rng.random(12) for _ in range(6)]
    rows = []
    for mode, faster_mps in (("non-reactive", 0.0), ("reactive", 10.0)):
        for seat, human in enumerate(humans):  # the humans' rows once per seat and mode, as evaluate_seats gives
            rows += [decision_rows(HUMAN, mode, seat, human), decision_rows("bc", mode, seat, human + faster_mps)]
    tracks = pd.concat(rows, ignore_index=True)
    table = distribution_table(tracks, {"BC": ["bc"]}, 0.5).splitlines()
    assert table[2].startswith("| BC | non-reactive | 0.00 [") and table[3].startswith("| BC | reactive | 10.00 [")
    for mode, line in (("non-reactive", table[2]), ("reactive", table[3])):
        alone = distribution_table(tracks[tracks["mode"] == mode], {"BC": ["bc"]}, 0.5).splitlines()
        assert alone[2] == line


def test_a_baseline_of_one_run_is_paired_with_each_training_run_of_a_method():
    """BC's three runs are 2, 3 and 4 m farther than IDM's one run in every seat: BC - IDM is their mean, +3 m, and
    its interval spans the runs' spread (t over three runs); the same runs against three copies of IDM agree."""
    errors = np.random.default_rng(4).uniform(10.0, 60.0, 16)
    idm = seat_rows(errors, "idm")
    runs = [seat_rows(errors + offset, f"bc_s{offset}") for offset in (2, 3, 4)]
    metrics = pd.concat([idm, *runs], ignore_index=True)
    methods = {"IDM": ["idm"], "BC": [f"bc_s{offset}" for offset in (2, 3, 4)]}
    table = track_table(metrics, methods, [("BC", "IDM")])
    row = next(line for line in table.splitlines() if line.startswith("| BC - IDM"))
    assert "| +3.00 [" in row and "*" in row
    copies = track_table(metrics, {**methods, "IDM": ["idm"] * 3}, [("BC", "IDM")])
    assert next(line for line in copies.splitlines() if line.startswith("| BC - IDM")) == row


def test_the_distributions_differences_are_paired_by_seat():
    """Two drivers 1 and 3 m/s faster than the humans in every seat of very different speeds: their distances differ
    by 2 m/s, with no spread when the seats are resampled together."""
    rng = np.random.default_rng(5)
    humans = [rng.normal(25.0, 6.0) + rng.random(12) for _ in range(8)]
    rows = []
    for seat, human in enumerate(humans):
        rows += [decision_rows(HUMAN, "reactive", seat, human), decision_rows("near", "reactive", seat, human + 1.0),
                 decision_rows("far", "reactive", seat, human + 3.0)]
    table = distribution_table(pd.concat(rows, ignore_index=True), {"near": ["near"], "far": ["far"]}, 0.5,
                               [("far", "near")]).splitlines()
    assert table[-1].startswith("| far - near | reactive | +2.00 [+2.00, +2.00] * | +0.00 [+0.00, +0.00] |")


def test_a_measure_no_episode_defines_is_left_out_of_the_table():
    """15 s seats reach the 15 s horizon but not the 20 s one; an older evaluation recorded no 2 s error."""
    metrics = seat_rows(np.full(16, 10.0), "bc").assign(position_error_15s_m=15.0, position_error_20s_m=np.nan)
    heading = track_table(metrics, {"BC": ["bc"]}).splitlines()[0]
    assert "position error 15 s [m]" in heading and "position error 10 s [m]" in heading
    assert "position error 20 s [m]" not in heading and "position error 2 s [m]" not in heading
    assert "speed RMSE" not in heading and "driving score" in heading


def test_a_table_of_no_episodes_is_empty_not_a_heading_without_columns():
    """The log study's phase table of a phase no seat is in (0 of 180 entering seats) printed a malformed table."""
    metrics = seat_rows(np.full(16, 10.0), "bc")
    assert track_table(metrics.iloc[:0], {"BC": ["bc"]}, [("BC", "BC")]) == ""
    assert track_table(metrics, {"BC": ["bc"]}).splitlines()[1].count("---") > 2
