"""What the SUMO steps of an ego's decision periods say about safety, beyond the traffic view read at decisions:
the ego's jerk, from its acceleration at every step, and how hard the vehicle behind in the lane the ego changes
into brakes after the change starts (a cut-in), from that vehicle's acceleration at every step while it is watched
(`CUT_IN_WINDOW_S`). `sumo_rail.evaluation.safety` turns the readings into episode measures.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from sumo_rail.sim.vehicles import EgoState, Neighbours, PeriodReport

CUT_IN_WINDOW_S = 3.0
"""How long the follower in the ego's new lane is watched after the ego's lane change starts [s]."""
READINGS = ("jerk_max_mps3", "jerk_mean_mps3", "cut_in_follower_accel_mps2", "cut_ins")
"""A decision's readings (its `info` keys): the period's largest and mean absolute jerk of the ego [m/s^3], the
lowest acceleration of the followers watched after cut-ins [m/s^2] (inf: none watched; not NaN, so that two equal
episodes have equal infos), and the cut-ins whose
follower starts to be watched at this decision (0 or 1)."""
NO_READINGS = {"jerk_max_mps3": 0.0, "jerk_mean_mps3": 0.0, "cut_in_follower_accel_mps2": math.inf, "cut_ins": 0}


def jerks(accelerations_mps2: Sequence[float], previous_mps2: float | None, step_length_s: float) -> list[float]:
    """|change of acceleration| / step length between consecutive steps [m/s^3]: the first step against
    `previous_mps2` (the last step before; None at an episode's first period, where it has none). Python floats:
    for a period's few steps, cheaper than numpy's calls, with the same arithmetic."""
    series = list(accelerations_mps2) if previous_mps2 is None else [previous_mps2, *accelerations_mps2]
    return [abs(after - before) / step_length_s for before, after in itertools.pairwise(series)]


def jerk_readings(period_jerks: list[float]) -> tuple[float, float]:
    """(largest, mean) of a period's jerks, 0 for none; the mean is numpy's, bit for bit: numpy's pairwise
    summation adds fewer than 8 values one after the other, as Python does here (a period of 5 steps has 5), and
    longer periods are summed by numpy itself."""
    count = len(period_jerks)
    if not count:
        return 0.0, 0.0
    if count < 8:
        total = 0.0
        for jerk in period_jerks:
            total += jerk
    else:
        total = float(np.add.reduce(np.array(period_jerks)))
    return max(period_jerks), total / count


def nearest_follower(ego: EgoState, neighbours: Neighbours, lane: int) -> str | None:
    """The id of the nearest vehicle whose front is behind the ego's rear in `lane`, if any is seen."""
    behind = (neighbours.lane == lane) & (neighbours.lane_position_m < ego.lane_position_m - ego.length_m)
    if not behind.any():
        return None
    return neighbours.ids[int(np.argmax(np.where(behind, neighbours.lane_position_m, -np.inf)))]


class PeriodSafety:
    """One ego's safety readings over its episode: which followers to watch in the next period (`watched`), and
    each period's readings (`update`)."""

    def __init__(self, step_length_s: float, decision_period_s: float) -> None:
        self.step_length_s = step_length_s
        self._window = round(CUT_IN_WINDOW_S / decision_period_s)
        self._watching: dict[str, int] = {}
        """Follower id -> periods it is still watched."""
        self._last_acceleration_mps2: float | None = None

    def watched(self) -> tuple[str, ...]:
        """The vehicles whose acceleration the next period's steps should read."""
        return tuple(self._watching)

    def update(self, report: PeriodReport, ego: EgoState | None, neighbours: Neighbours | None,
               requested_lane: int | None, was_changing: bool) -> dict[str, float]:
        """The readings of a period (`READINGS`), after which the ego is `ego` among `neighbours` (None: it is gone);
        `requested_lane`: the lane its decision asked to change to (None: none), `was_changing`: a change was under
        way before it. A change that started in the period (the ego between lanes, or in the requested lane, after a
        request made while no change was under way) is a cut-in: the nearest follower in that lane is watched from
        now on."""
        period_jerks = jerks(report.accelerations_mps2, self._last_acceleration_mps2, self.step_length_s)
        if report.accelerations_mps2:
            self._last_acceleration_mps2 = report.accelerations_mps2[-1]
        lowest = math.inf
        if self._watching:
            lowest = min(report.watched_min_acceleration_mps2.get(vehicle, math.inf) for vehicle in self._watching)
            self._watching = {vehicle: left - 1 for vehicle, left in self._watching.items() if left > 1}
        cut_ins = 0
        if (ego is not None and neighbours is not None and requested_lane is not None and not was_changing
                and (ego.changing_lane or ego.lane == requested_lane)):
            follower = nearest_follower(ego, neighbours, requested_lane)
            if follower is not None:
                self._watching[follower] = self._window
                cut_ins = 1
        jerk_max, jerk_mean = jerk_readings(period_jerks)
        return {"jerk_max_mps3": jerk_max, "jerk_mean_mps3": jerk_mean, "cut_in_follower_accel_mps2": lowest,
                "cut_ins": cut_ins}
