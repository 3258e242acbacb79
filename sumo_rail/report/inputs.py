"""Read what `sumo-rail report` plots: training run folders and evaluation metrics files, validated on the way in."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa

from sumo_rail.datasets import describe, read_json_record, read_metadata
from sumo_rail.drivers.policies import Policy, load_policy
from sumo_rail.evaluation.distributions import summary_path
from sumo_rail.evaluation.evaluate import DECISIONS, decisions_path
from sumo_rail.evaluation.summary import EPISODE_MEASURES
from sumo_rail.runners.tables import EPISODE_METRICS
from sumo_rail.sim.actions import Action

TRAINING_LOG = "training_log"
DAGGER_LOG = "dagger_log"
LOG_COLUMNS = ("iteration", "env_steps", "return_mean", "return_max", "return_std", "wall_time_s")
"""Columns of log.parquet the report needs (a DAgger run's has no return: NaN)."""
RETURN_COLUMNS = ("return_mean", "return_max", "return_std")
EVAL_COLUMNS = ("eval_agreement", "eval_lane_change_recall", "eval_average_speed_kmh", "eval_overtakes",
                "eval_lane_changes", "eval_collisions")
"""Validation columns of log.parquet the report shows; optional (older runs have none), null where not evaluated."""
ACTION_NAMES = tuple(action.name.lower() for action in Action)
"""Output units of every policy, in action order."""


class ReportError(ValueError):
    """An input of the report cannot be used (message is one sentence)."""


@dataclass(frozen=True)
class Run:
    """A training run folder as the report sees it."""

    name: str
    """Unique label: the folder name (suffixed _2, _3... when two folders share it)."""
    folder: Path
    settings: dict[str, Any]
    """run.json's settings ({} when run.json is absent)."""
    log: pd.DataFrame
    """log.parquet sorted by iteration, with `cumulative_env_steps` added and every EVAL_COLUMNS column present."""
    policies: dict[str, tuple[Policy, str]]
    """'BC' and/or the trained policy ('RAIL', or 'GAIL' for a `sumo-rail gail` run) -> (policy, file name); the
    trained one is policy_latest.npz (what the tables evaluate), else policy_best.npz."""
    observation_names: list[str]
    method: str = "RAIL"
    """'RAIL', 'GAIL', 'DAgger' (no return) or 'PPO' (`ppo`, whose return is the environment's reward, not a
    discriminator's)."""
    road: str = "?"
    """The road (scenario.kind) it trained on, as run.json says ('?' without it)."""

    @property
    def return_name(self) -> str:
        """What the log's return is: "D return" (a discriminator's) or "env return" (a `ppo` run's)."""
        return "env return" if self.method == "PPO" else "D return"

    @property
    def step_name(self) -> str:
        """What one row of the log is: a PPO "update" (a `gail` or `ppo` run), a DAgger "round" or an "iteration"."""
        return {"PPO": "update", "GAIL": "update", "DAgger": "round"}.get(self.method, "iteration")

    @property
    def kind(self) -> str:
        """'linear', 'mlp (10 hidden)' or '?'."""
        policy = next(iter(self.policies.values()), None)
        kind = policy[0].shape.kind if policy else self.settings.get("kind", "?")
        hidden = policy[0].shape.hidden if policy else self.settings.get("hidden")
        return f"mlp ({hidden} hidden)" if kind == "mlp" else str(kind)

    @property
    def evaluated(self) -> pd.DataFrame:
        """The log rows that hold validation metrics."""
        return self.log.dropna(subset=["eval_average_speed_kmh"])


@dataclass(frozen=True)
class Inputs:
    runs: list[Run]
    metrics: pd.DataFrame | None
    """All episodes of the metrics files, concatenated (driver names made unique across files), or None."""
    metrics_files: list[Path]
    decisions: pd.DataFrame | None = None
    """The per-decision records beside the metrics files (NAME.decisions.parquet), when every file has them."""
    route: bool = False
    """Some metrics file is of a road with a feature, whose route measures are shown even when none happened."""
    summary: pd.DataFrame | None = None
    """Without them, the decision summary beside a single metrics file (NAME.distributions.parquet,
    `evaluation.distributions.decision_summary`): what the report reads of the records."""


def read_inputs(paths: list[Path]) -> Inputs:
    """Sort `paths` into run folders and metrics files and read them all; any unusable one raises ReportError."""
    runs: list[Run] = []
    metrics: list[tuple[Path, pd.DataFrame]] = []
    for path in paths:
        if path.is_dir():
            runs.append(read_run(path, _unique(path.name, [run.name for run in runs])))
        else:
            metrics.append((path, read_metrics(path)))
    if len({run.return_name for run in runs}) > 1:
        ppo = next(run for run in runs if run.method == "PPO")
        other = next(run for run in runs if run.method != "PPO")
        raise ReportError(f"{ppo.folder} is a ppo run, whose return is the environment's reward, and {other.folder} "
                          f"returns a discriminator's, which do not share a plot: report them separately")
    decisions = [(path, read_decisions(decisions_path(path))) for path, _ in metrics
                 if decisions_path(path).is_file()]
    route = any(read_metadata(path).get("config", {}).get("scenario", {}).get("kind", "straight") != "straight"
                for path, _ in metrics)
    every = metrics and len(decisions) == len(metrics)
    summary = (pd.read_parquet(summary_path(metrics[0][0])) if not every and len(metrics) == 1
               and summary_path(metrics[0][0]).is_file() else None)
    return Inputs(runs, _concatenate(metrics), [path for path, _ in metrics],
                  _concatenate(decisions) if every else None, route, summary)


def read_run(folder: Path, name: str) -> Run:
    """A run folder written by `sumo-rail train`, `dagger`, `gail` or `ppo`: log.parquet (required), run.json and
    the policies (optional)."""
    log_path = folder / "log.parquet"
    if not log_path.is_file():
        raise ReportError(f"{folder} is not a training run folder: it has no log.parquet")
    kind = read_metadata(log_path).get("kind")
    if kind not in (TRAINING_LOG, DAGGER_LOG):
        raise ReportError(f"{log_path} holds {kind!r} data, not a training log")
    log = _read_parquet(log_path)
    if kind == DAGGER_LOG:
        log = log.assign(**dict.fromkeys((column for column in RETURN_COLUMNS if column not in log), float("nan")))
    _require_columns(log, LOG_COLUMNS, log_path)
    if log.empty:
        raise ReportError(f"{log_path} holds no iterations yet")
    log = log.sort_values("iteration", ignore_index=True)
    for column in EVAL_COLUMNS:
        log[column] = pd.to_numeric(log[column], errors="coerce") if column in log else float("nan")
    log["cumulative_env_steps"] = log["env_steps"].cumsum()
    settings, method, road = _read_run_record(folder / "run.json")
    policies: dict[str, tuple[Policy, str]] = {}
    metadata: dict[str, Any] = {}
    for label, files in (("BC", ("policy_bc.npz",)), (method, ("policy_latest.npz", "policy_best.npz"))):
        file = next((file for file in files if (folder / file).is_file()), None)
        if file is not None:
            policy, metadata = load_policy(folder / file)
            policies[label] = (policy, file)
    if len({policy.shape for policy, _ in policies.values()}) > 1:
        raise ReportError(f"the BC and {method} policies in {folder} have different shapes")
    return Run(name, folder, settings, log, policies, _observation_names(policies, metadata), method, road)


def read_metrics(path: Path) -> pd.DataFrame:
    """An episode metrics file written by `sumo-rail evaluate --out`."""
    kind = read_metadata(path).get("kind")
    if kind == TRAINING_LOG:
        raise ReportError(f"{path} is a training log; pass its run folder {path.parent} instead")
    if kind != EPISODE_METRICS:
        raise ReportError(f"{path} holds {kind!r} data, not evaluation metrics")
    metrics = _read_parquet(path)
    _require_columns(metrics, ("policy", "seed", *EPISODE_MEASURES), path)
    if metrics.empty:
        raise ReportError(f"{path} holds no episodes")
    return metrics


def read_decisions(path: Path) -> pd.DataFrame:
    """The per-decision records written by `sumo-rail evaluate --out` beside its metrics file."""
    kind = read_metadata(path).get("kind")
    if kind != DECISIONS:
        raise ReportError(f"{path} holds {kind!r} data, not per-decision records")
    decisions = _read_parquet(path)
    _require_columns(decisions, ("policy", "action", "speed_mps", "headway_s", "lane"), path)
    return decisions


def file_label(name: str) -> str:
    """`name` reduced to characters safe in file names and Markdown links."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def _read_parquet(path: Path) -> pd.DataFrame:
    try:
        return pd.read_parquet(path, page_checksum_verification=True)
    except (pa.ArrowException, OSError, ValueError) as error:
        raise ReportError(f"{path} is damaged or not a readable Parquet file ({describe(error)})") from error


def _require_columns(table: pd.DataFrame, columns: tuple[str, ...], path: Path) -> None:
    missing = [column for column in columns if column not in table]
    if missing:
        raise ReportError(f"{path} lacks the column(s) {', '.join(missing)}")
    not_numbers = [column for column in columns if column != "policy"
                   and not pd.api.types.is_numeric_dtype(table[column])]
    if not_numbers:
        raise ReportError(f"{path} has non-numeric column(s) {', '.join(not_numbers)}")


def _read_run_record(path: Path) -> tuple[dict[str, Any], str, str]:
    """run.json's settings, the training method ('GAIL' for a gail run, 'PPO' for a ppo run, 'DAgger' for a dagger
    run, else 'RAIL') and the road (scenario.kind: 'straight' in a config written before roads had kinds, the
    only road then); ({}, 'RAIL', '?') without run.json."""
    if not path.is_file():
        return {}, "RAIL", "?"
    record = read_json_record(path, "run record")
    settings = record.get("settings")
    if not isinstance(settings, dict):
        raise ReportError(f"{path} is not a sumo-rail run record")
    scenario = record.get("config", {}).get("scenario", {}) if isinstance(record.get("config"), dict) else {}
    return (settings, {"gail_run": "GAIL", "ppo_run": "PPO", "dagger_run": "DAgger"}.get(str(record.get("kind")),
                                                                                         "RAIL"),
            str(scenario.get("kind", "straight")) if isinstance(scenario, dict) and scenario else "?")


def _observation_names(policies: dict[str, tuple[Policy, str]], metadata: dict[str, Any]) -> list[str]:
    """The stored feature names when they fit the policies, else x0, x1..."""
    if not policies:
        return []
    size = next(iter(policies.values()))[0].shape.observation_size
    names = metadata.get("observation_names")
    if isinstance(names, list) and len(names) == size:
        return [str(name) for name in names]
    return [f"x{index}" for index in range(size)]


def _unique(name: str, taken: list[str]) -> str:
    label, count = file_label(name), 1
    while label in taken:
        count += 1
        label = f"{file_label(name)}_{count}"
    return label


def _concatenate(files: list[tuple[Path, pd.DataFrame]]) -> pd.DataFrame | None:
    """One table of all episodes; a driver name found in several files becomes 'name [file stem]' in each."""
    if not files:
        return None
    counts = pd.Series([name for _, table in files for name in dict.fromkeys(table["policy"])]).value_counts()
    shared = set(counts[counts > 1].index)
    tables = [table.assign(policy=[f"{name} [{path.stem}]" if name in shared else name for name in table["policy"]])
              for path, table in files]
    return pd.concat(tables, ignore_index=True)
