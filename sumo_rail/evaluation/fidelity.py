"""How a driver's decisions compare with the expert's, asked at every decision of the driver's own episode.

The expert is a pure function of the traffic view, so at each decision of any driver it can be asked what it
would do in that very traffic without changing what the driver does (on-policy agreement). `AgreementObserver`
watches an episode's decisions (a decision observer, `sumo_rail.sim.observers`) and keeps:
- the 5x5 confusion counts (driver action x expert action), from which every agreement measure follows
  (`agreement_counts`): overall agreement, lane-change recall and precision, and agreement split into its
  lateral part (keep lane / left / right) and its longitudinal part (set-point up / down / hold);
- per decision, what a traffic engineer compares between drivers: speed, time headway to the leader in the
  ego's lane (capped; NaN with no leader within the context radius), lane, set-point, and the gaps in the
  target lane when a lane change was accepted.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sumo_rail.action_config import ActionConfig
from sumo_rail.evaluation.safety import HEADWAY_CAP_S, time_headway
from sumo_rail.runners.rollout import Driver
from sumo_rail.sim.actions import Action, paper_action
from sumo_rail.sim.observers import Decision, Moment
from sumo_rail.sim.traffic import lane_gaps

ACTION_NAMES = tuple(action.name.lower() for action in Action)
CONFUSION_COLUMNS = tuple(f"confusion_{driver}_{expert}" for driver in ACTION_NAMES for expert in ACTION_NAMES)
"""Episode columns: decisions where the driver chose the first action and the expert would have chosen the second,
driver-major (row = driver action, column = expert action)."""
RATE_COLUMNS = ("agreement", "lane_change_recall", "lane_change_precision", "lateral_agreement",
                "longitudinal_agreement")
"""Per-episode rates derived from the confusion counts (NaN where a rate has no decisions to count)."""
_LANE_CHANGES = (Action.LANE_LEFT, Action.LANE_RIGHT)
_LATERAL = np.array([0, 0, 0, 1, 2])
"""Lateral part of each action: keep lane (keep, accelerate, decelerate), left, right."""
_LONGITUDINAL = np.array([0, 1, 2, 0, 0])
"""Longitudinal part of each action: hold (keep, lane changes), set-point up, set-point down."""
_SAME_LATERAL = _LATERAL[:, None] == _LATERAL[None, :]
_SAME_LONGITUDINAL = _LONGITUDINAL[:, None] == _LONGITUDINAL[None, :]


def agreement_counts(confusion: np.ndarray) -> dict[str, np.ndarray]:
    """Counts behind every agreement measure, for confusion matrices of shape (..., 5, 5).

    Returns arrays of shape (...): decisions, agreements, lateral and longitudinal agreements, expert lane
    changes (decisions where the expert would change lanes), driver lane changes, and lane-change matches
    (both chose the same change)."""
    confusion = np.asarray(confusion)
    lane_changes = list(map(int, _LANE_CHANGES))
    diagonal = np.diagonal(confusion, axis1=-2, axis2=-1)
    return {
        "decisions": confusion.sum(axis=(-2, -1)),
        "agreements": diagonal.sum(axis=-1),
        "lateral_agreements": (confusion * _SAME_LATERAL).sum(axis=(-2, -1)),
        "longitudinal_agreements": (confusion * _SAME_LONGITUDINAL).sum(axis=(-2, -1)),
        "expert_lane_changes": confusion[..., :, lane_changes].sum(axis=(-2, -1)),
        "driver_lane_changes": confusion[..., lane_changes, :].sum(axis=(-2, -1)),
        "lane_change_matches": diagonal[..., lane_changes].sum(axis=-1),
    }


RATES: dict[str, tuple[str, str]] = {
    "agreement": ("agreements", "decisions"),
    "lane_change_recall": ("lane_change_matches", "expert_lane_changes"),
    "lane_change_precision": ("lane_change_matches", "driver_lane_changes"),
    "lateral_agreement": ("lateral_agreements", "decisions"),
    "longitudinal_agreement": ("longitudinal_agreements", "decisions"),
}
"""Each rate as (numerator, denominator) of `agreement_counts`, in RATE_COLUMNS order."""


def rates(confusion: np.ndarray) -> dict[str, float]:
    """The rates of one confusion matrix (NaN where the denominator is 0)."""
    counts = agreement_counts(confusion)
    return {name: float(counts[top] / counts[bottom]) if counts[bottom] else float("nan")
            for name, (top, bottom) in RATES.items()}


class AgreementObserver:
    """Watches one episode's decisions (an observer of each reset and decision, `sumo_rail.sim.observers`) and asks
    `reference` (the expert: any driver) at each what it would have done in what the driver saw. Under the
    acceleration interface (`actions`) the driver's action is compared as the paper action it counts as
    (`sim.actions.paper_action`): its lane change, else the sign of its acceleration, against the expert's."""

    every_step = False

    def __init__(self, reference: Driver, actions: ActionConfig | None = None, name: str | None = None) -> None:
        self.reference = reference
        self.name = name
        """The reference's name, the "reference" column of an evaluation's record (`columns`)."""
        self.actions = actions or ActionConfig()
        self._accelerating = self.actions.interface == "acceleration"
        self.confusion = np.zeros((len(Action), len(Action)), dtype=np.int64)
        self._rows: list[tuple[Any, ...]] = []

    def __call__(self, moment: Moment) -> None:
        for decision in moment.decisions():
            self._add(decision)

    def _add(self, decision: Decision) -> None:
        traffic, action, info = decision.traffic, decision.action, decision.info
        expert_action = int(self.reference(decision.observation, traffic))
        if self._accelerating:
            action = int(paper_action(action, self.actions))
        self.confusion[action, expert_action] += 1
        ego = traffic.ego
        leader = lane_gaps(traffic, ego.lane)
        headway = min(time_headway(leader.front_gap_m, ego.speed_mps), HEADWAY_CAP_S) if np.isfinite(
            leader.front_gap_m) else np.nan
        front_gap = rear_gap = np.nan
        if action in _LANE_CHANGES and not ego.changing_lane and info.get("lane_change_in_progress", False):
            target = lane_gaps(traffic, ego.lane + (1 if action == Action.LANE_LEFT else -1))
            front_gap = target.front_gap_m if np.isfinite(target.front_gap_m) else np.nan
            rear_gap = target.rear_gap_m if np.isfinite(target.rear_gap_m) else np.nan
        self._rows.append((action, expert_action, ego.speed_mps, traffic.set_point_mps, ego.lane, headway,
                           front_gap, rear_gap))

    def episode_columns(self) -> dict[str, Any]:
        """The episode's confusion counts and rates (CONFUSION_COLUMNS, RATE_COLUMNS)."""
        return {**dict(zip(CONFUSION_COLUMNS, self.confusion.ravel().tolist(), strict=True)), **rates(self.confusion)}

    def decision_columns(self) -> dict[str, np.ndarray]:
        """One entry per decision in each of DECISION_FIELDS."""
        columns = list(zip(*self._rows, strict=True)) if self._rows else [()] * len(DECISION_FIELDS)
        return {name: np.asarray(values, dtype=kind) for (name, kind), values in
                zip(DECISION_FIELDS.items(), columns, strict=True)}

    def columns(self, env: object, metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
        """An evaluation observer's record (`protocol.EpisodeObserver`): the reference's name, the confusion counts and
        rates; the DECISION_FIELDS."""
        return {"reference": self.name, **self.episode_columns()}, self.decision_columns()


DECISION_FIELDS: dict[str, type] = {
    "action": np.int8, "expert_action": np.int8, "speed_mps": np.float64, "set_point_mps": np.float64,
    "lane": np.int8, "headway_s": np.float64, "accepted_front_gap_m": np.float64, "accepted_rear_gap_m": np.float64,
}
"""Per-decision records: the driver's and the expert's action, speed [m/s], set-point [m/s], lane (0 = right),
time headway [s] (NaN: no leader), and the target lane's front and rear gaps [m] at an accepted lane change (NaN
otherwise or where nobody was seen)."""
