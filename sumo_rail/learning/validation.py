"""Validation during training (`train`, `dagger`): the policy's episode metrics and its agreement with the expert on
validation seeds, every few iterations, as the training log's eval_* columns."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sumo_rail.config import Config
from sumo_rail.drivers.policies import Policy
from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.evaluation.statistics import interval, ratio
from sumo_rail.evaluation.summary import measure_samples
from sumo_rail.runners.backends import RolloutBackend
from sumo_rail.runners.rollout import DriverSpec, PolicyDriver
from sumo_rail.seeding import Purpose, episode_seeds

VALIDATION_BASE_SEED = 1_000_000
"""Validation episodes use evaluation-class seeds from this base, far from `evaluate`'s default test seeds."""
VALIDATION_METRICS = ("agreement", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes",
                      "lane_changes", "longitudinal_reward", "lateral_reward", "collisions", "missed_exits",
                      "lane_end_stops")
"""Measures the log holds as eval_<measure>: the agreement rates with the expert (pooled over the validation
decisions) and the episode metrics' means, route failures (missed exits, stops at a lane end) beside collisions.
Logs written before some of them lack them (`with_validation_columns`)."""
VALIDATION_INTERVAL = ("eval_agreement_low", "eval_agreement_high")
"""The log's bounds of the 95% interval of eval_agreement (bootstrap over the validation episodes, as `evaluate`
gives it; NaN with one episode). Logs written before them lack them (`with_validation_columns`)."""


@dataclass(frozen=True)
class Validation:
    """Evaluate the policy every `every` iterations (and after the last) on `episodes` validation seeds."""

    every: int = 0
    """0: never."""
    episodes: int = 8

    def __post_init__(self) -> None:
        if self.every < 0 or self.episodes < 1:
            raise ValueError(f"validation needs every >= 0 and episodes >= 1, got {self}")

    def due(self, iteration: int, last: int) -> bool:
        """Whether the policy after `iteration` (0-based) is evaluated in a run of `last` + 1 iterations."""
        return self.every > 0 and ((iteration + 1) % self.every == 0 or iteration == last)


def validation_columns() -> tuple[str, ...]:
    """The log's eval_<measure> columns and the agreement's interval."""
    return (*(f"eval_{metric}" for metric in VALIDATION_METRICS), *VALIDATION_INTERVAL)


def with_validation_columns(row: dict[str, Any]) -> dict[str, Any]:
    """A log row of a run started before some validation column existed, with that column added (null)."""
    return row | {name: None for name in validation_columns() if name not in row}


def validate(policy: Policy, config: Config, backend: RolloutBackend, validation: Validation,
             expert: DriverSpec) -> dict[str, float]:
    """VALIDATION_METRICS of `policy` on the validation seeds and warm states, as eval_<measure>, agreement with
    `expert` (`resolve_expert`), and the agreement's 95% interval (VALIDATION_INTERVAL)."""
    seeds = episode_seeds(Purpose.EVALUATE, VALIDATION_BASE_SEED, validation.episodes)
    evaluation = evaluate([PolicyDriver(policy, "policy")], config, seeds, backend, expert, pool="validation")
    samples = measure_samples(evaluation.metrics, route=True)
    agreement = interval(samples["agreement"])
    return {**{f"eval_{measure}": float(ratio(samples[measure])) for measure in VALIDATION_METRICS},
            "eval_agreement_low": agreement.low, "eval_agreement_high": agreement.high}
