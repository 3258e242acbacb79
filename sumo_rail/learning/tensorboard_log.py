"""TensorBoard logs of training runs (optional extra `sumo-rail[tensorboard]`): every numeric column of each
log row (train: one per ARS iteration; gail: one per PPO update) as the scalar `PREFIX/COLUMN`, against the run's
cumulative environment steps (decisions). The run folder's log.parquet stays the source of truth; this is a view
of it for TensorBoard users. On --resume the count continues from the steps already in log.parquet.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq

INSTALL_HINT = "pip install 'sumo-rail[tensorboard]'"


class TensorBoardError(RuntimeError):
    """TensorBoard logging is not possible (message is one sentence)."""


def require_tensorboard() -> None:
    """Raise TensorBoardError with the install hint unless torch's SummaryWriter can be used."""
    try:
        import tensorboard  # noqa: F401
        from torch.utils.tensorboard import SummaryWriter  # noqa: F401
    except ImportError as error:
        raise TensorBoardError(f"--tensorboard needs tensorboard, which is not installed; install it with "
                               f"{INSTALL_HINT}") from error


class TensorBoardLogger:
    """Writes log rows to TensorBoard event files in `log_dir`, scalars named `prefix/column`; the folder and its
    event file are created with the first row (so a log folder inside a new run folder does not block the run)."""

    def __init__(self, log_dir: Path, prefix: str, run_folder: Path | None = None) -> None:
        require_tensorboard()
        self._log_dir = Path(log_dir)
        self._writer: Any = None
        self._prefix = prefix
        self._run_folder = run_folder
        self._env_steps: int | None = None

    def log(self, row: dict[str, Any]) -> None:
        """One log row (with "iteration" and "env_steps", the row's own decisions); None and NaN are skipped."""
        if self._writer is None:
            from torch.utils.tensorboard import SummaryWriter

            try:
                self._log_dir.mkdir(parents=True, exist_ok=True)
            except OSError as error:
                raise TensorBoardError(f"cannot create {self._log_dir}: {error.strerror or error}") from error
            self._writer = SummaryWriter(log_dir=str(self._log_dir))
        if self._env_steps is None:
            self._env_steps = _steps_before(self._run_folder, int(row.get("iteration", 0)))
        self._env_steps += int(row.get("env_steps", 0))
        for name, value in row.items():
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                continue
            self._writer.add_scalar(f"{self._prefix}/{name}", value, global_step=self._env_steps)
        self._writer.flush()

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()


def _steps_before(run_folder: Path | None, iteration: int) -> int:
    """Environment steps of the iterations before `iteration` in the run folder's log (0 for a new run)."""
    if run_folder is None or iteration == 0 or not (Path(run_folder) / "log.parquet").is_file():
        return 0
    log = pq.read_table(Path(run_folder) / "log.parquet", columns=["iteration", "env_steps"]).to_pandas()
    return int(log.loc[log["iteration"] < iteration, "env_steps"].sum())
