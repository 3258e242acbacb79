"""How the commands that run for long behave: errors a user can cause as one sentence, Ctrl-C and SIGTERM, the
progress bar, the backend and TensorBoard closed on the way out, and the lines they print about training."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import signal
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

import click

if TYPE_CHECKING:
    from sumo_rail.learning.bc import BcReport


USER_ERRORS = ("DatasetError", "PolicyFileError", "SimulationError", "EgoCouldNotEnter", "ConfigError")
"""Exceptions a user causes (a file, a setting): raised in a worker's task, their message alone is the sentence."""


@contextlib.contextmanager
def library_errors() -> Iterator[None]:
    """Errors a user can cause in the library become one-sentence click errors (exit 1), never tracebacks; one
    raised by a worker's task says what it says, without the backend's "task N raised" around it."""
    from sumo_rail.datasets import DatasetError
    from sumo_rail.drivers.policies import PolicyFileError
    from sumo_rail.runners.backends import BackendError, TaskError
    from sumo_rail.sim.simulation import SimulationError

    try:
        yield
    except TaskError as error:
        raise click.ClickException(error.detail if error.raised in USER_ERRORS else str(error)) from error
    except (BackendError, DatasetError, PolicyFileError, SimulationError) as error:
        raise click.ClickException(str(error)) from error


@contextlib.contextmanager
def interruptible_run(bar: AbstractContextManager[Any], interrupted: str | Callable[[], str] | None = None,
                      backend: AbstractContextManager[Any] | None = None,
                      board: AbstractContextManager[Any] | None = None,
                      errors: tuple[type[Exception], ...] = ()) -> Iterator[Any]:
    """A long command's work: Ctrl-C or SIGTERM end it with the one sentence `interrupted` (or what it returns when it
    is called then; without it, `stopped`: which of the command's outputs were written) (exit 1), even when it was
    started with SIGINT ignored; errors a user can cause (`library_errors`, and `errors`) are one sentence too. The
    TensorBoard logger `board` (`tensorboard_logger`), the `backend` and the progress `bar` are entered in that
    order and closed on the way out; yields what `board` yields (None without it)."""
    make_interruptible()
    with library_errors(), board or contextlib.nullcontext() as logger, backend or contextlib.nullcontext(), bar:
        try:
            yield logger
        except errors as error:
            raise click.ClickException(str(error)) from error
        except KeyboardInterrupt:
            ignore_stop_signals()  # more Ctrl-Cs must not break the closing of the backend and the bar
            sentence = stopped() if interrupted is None else interrupted if isinstance(interrupted, str) else \
                interrupted()
            raise click.ClickException(sentence) from None
        _OUTPUTS.done = True  # a stop from here on (closing, the summary) comes after the work


def kept_until_resume(out: Path, step: str, checkpoint: str = "checkpoint.pt") -> str:
    """What an interrupted resumable run says: its folder keeps its last complete `step` (iteration, round), or, when
    it was stopped before its first was saved (no `checkpoint` in `out`), that there is nothing to resume."""
    if (out / checkpoint).is_file():
        return f"interrupted; {out} keeps its last complete {step}, continue with --resume"
    unsaved = f"interrupted before the first {step} was saved, so there is nothing to resume"
    if out.is_dir() and any(out.iterdir()):  # a run folder begun: a new run needs it empty
        return f"{unsaved}: remove {out} and run the command again"
    return f"{unsaved}: run the command again"


def sb3_progress(bar: Any, row: dict[str, Any], steps_per_update: int) -> None:
    """Move a gail or ppo progress bar (in timesteps) to the end of the update of log `row`; a resumed run's bar
    starts from the updates done before at its first new row, and its rate counts this run's timesteps alone (as
    `train`'s counts its own iterations)."""
    from .progress import advance_to, start_at

    if bar.n == 0 and row["iteration"] > 0:
        start_at(bar, row["iteration"] * steps_per_update, restart_clock=False)
    advance_to(bar, (row["iteration"] + 1) * steps_per_update)


def sb3_interrupted(out: Path) -> Callable[[], str]:
    """What a gail or ppo run stopped outside its updates says (within them, the run stops at the update's end),
    read when it stops: whether its folder keeps an update by then."""
    return lambda: kept_until_resume(out, "update")


def sb3_outcome(result: Any, out: Path, critic_warmup: int) -> str:
    """The line a finished gail or ppo run prints (`result`: its GailResult or PpoResult), saying when the critic's
    warm-up kept the actor frozen in some or all of the updates; a ClickException when it was interrupted."""
    updates = f"{result.updates} PPO update{'s' * (result.updates != 1)}"
    if result.interrupted:
        raise click.ClickException(f"interrupted after {updates}; {out} keeps them, continue with --resume")
    frozen = min(critic_warmup, result.updates)
    first = "the first update" if frozen == 1 else f"the first {frozen} updates"
    note = ("" if not frozen else f"; the actor frozen in {first} for the critic's warm-up"
            if frozen < result.updates else f"; the actor frozen in {f'all {frozen}' if frozen > 1 else 'it'} for the "
            f"critic's warm-up, so the policy is the initial one")
    return f"trained {updates} ({result.timesteps} timesteps{note}); policy in {out / 'policy_latest.npz'}"


def bc_summary(report: BcReport, policy_path: Path) -> str:
    """One line on a behaviour-cloning result: train and held-out accuracy of the policy's decoded action (beside the
    logits' argmax's when it decodes otherwise, and the held-out accuracy of always choosing the commonest action),
    where the policy was saved."""
    holdout = "n/a" if report.holdout_accuracy is None else f"{report.holdout_accuracy:.3f}"
    if report.argmax_holdout_accuracy is not None:
        holdout += f", by the logits' argmax {report.argmax_holdout_accuracy:.3f}"
    if report.majority_accuracy is not None:
        holdout += f" (majority action {report.majority_accuracy:.3f})"
    return (f"behaviour cloning: train accuracy {report.train_accuracy:.3f}, holdout accuracy {holdout} "
            f"({report.holdout_rows} held-out decisions); saved {policy_path}")


def validation_summary(row: dict[str, Any], episodes: int) -> str:
    """A training log row's validation measures, agreement with the expert first, with its 95% interval over the
    `episodes` validation episodes (an estimate from a few episodes is rough; the interval says how rough)."""
    low, high = row.get("eval_agreement_low"), row.get("eval_agreement_high")
    spread = "" if low is None or math.isnan(low) else f" [{low:.3f}, {high:.3f}]"
    return (f"validation agreement {row['eval_agreement']:.3f}{spread} on {episodes} episode{'s' * (episodes != 1)} "
            f"(lane-change recall {row['eval_lane_change_recall']:.2f}), speed {row['eval_average_speed_kmh']:.1f} "
            f"km/h, overtakes {row['eval_overtakes']:.2f}, lane changes {row['eval_lane_changes']:.2f}, "
            f"{failures_summary(row, 'eval_', '.2f')}")


def failures_summary(counts: dict[str, Any], prefix: str = "", spec: str = "d") -> str:
    """Collisions and route failures (missed exits, stops at a lane end) of `counts` (`prefix` + measure, formatted
    by `spec`); a measure a row lacks (a log written before it) is left out."""
    names = {"collisions": "collisions", "missed_exits": "missed exits", "lane_end_stops": "stops at a lane end"}
    return ", ".join(f"{names[name]} {counts[prefix + name]:{spec}}" for name in names
                     if counts.get(prefix + name) is not None)


def make_interruptible() -> None:
    """Make SIGINT and SIGTERM raise KeyboardInterrupt, so that both stop a command as Ctrl-C does, even when it was
    started with SIGINT ignored (as a shell script's background jobs are); the first one stops it, and the signals
    after it are ignored while it closes (a burst of Ctrl-Cs would otherwise interrupt the closing)."""
    signal.signal(signal.SIGINT, _stop_once)
    signal.signal(signal.SIGTERM, _stop_once)


STARTING_INTERRUPTED = "interrupted before any work began; nothing was written"
"""What `sumo-rail` stopped while it starts (its imports, click's parsing), before a command began, says."""


@dataclasses.dataclass
class _Outputs:
    """The outputs of the command running in this process, each as it was before the command wrote it, and whether
    the command's work (`interruptible_run`) ended: what a stop says was written."""

    before: dict[Path, object] = dataclasses.field(default_factory=dict)
    done: bool = False


_OUTPUTS = _Outputs()


def begin_command() -> None:
    """A command begins: no output of it is known yet (a process may run several, as tests do)."""
    _OUTPUTS.before.clear()
    _OUTPUTS.done = False


def note_output(out: Path) -> None:
    """Count `out` (a file or a folder) among the command's outputs, as it is now, before the command writes it."""
    _OUTPUTS.before.setdefault(out, _version(out))


def _version(path: Path) -> object:
    """What tells one version of `path` from another: inode, modification time [ns] and size of the file, or of each
    file in the folder (None when it does not exist). A file replaced atomically has a new inode."""
    if path.is_dir():
        return frozenset((str(file), _version(file)) for file in path.rglob("*") if file.is_file())
    try:
        status = path.stat()
    except OSError:
        return None
    return status.st_ino, status.st_mtime_ns, status.st_size


def stopped() -> str:
    """The sentence of a command stopped by Ctrl-C or SIGTERM once it began: whether its work was done, which of its
    outputs were written (a file is written whole or not at all; a folder written in part may be incomplete before
    the work is done) and which were not."""
    written = [out for out, before in _OUTPUTS.before.items() if _version(out) != before]
    files = [out for out in written if _OUTPUTS.done or not out.is_dir()]
    begun = [out for out in written if out not in files]
    untouched = [out for out in _OUTPUTS.before if out not in written]
    parts = [f"{_listed(files)} {'was' if len(files) == 1 else 'were'} written"] if files else []
    if begun:
        parts.append(f"{_listed(begun)} {'was' if len(begun) == 1 else 'were'} begun and may be incomplete")
    if untouched or not written:
        parts.append("nothing was written" + (f" to {_listed(untouched, 'or')}" if untouched else ""))
    return f"interrupted{' after the work was done' * _OUTPUTS.done}; {'; '.join(parts)}"


def _listed(paths: list[Path], conjunction: str = "and") -> str:
    """`paths` as words: "a", "a and b", "a, b and c"."""
    names = [str(path) for path in paths]
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} {conjunction} {names[-1]}"


def end_quietly_while_starting() -> None:
    """Make SIGINT and SIGTERM end the process with the one sentence `STARTING_INTERRUPTED` (exit 1), wherever they
    arrive while `sumo-rail` starts (its imports, click's parsing), until a command begins and calls
    `make_interruptible`; SystemExit, not KeyboardInterrupt, so that no handler on the way turns it into a traceback."""
    signal.signal(signal.SIGINT, _end_starting)
    signal.signal(signal.SIGTERM, _end_starting)


def _end_starting(signal_number: int, frame: FrameType | None) -> None:
    ignore_stop_signals()
    raise SystemExit(f"Error: {STARTING_INTERRUPTED}")


def ignore_stop_signals() -> None:
    """Ignore SIGINT and SIGTERM from now on (the command is already stopping)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def _stop_once(signal_number: int, frame: FrameType | None) -> None:
    ignore_stop_signals()
    raise KeyboardInterrupt


@contextlib.contextmanager
def tensorboard_logger(tensorboard_dir: Path | None, prefix: str, run_folder: Path) -> Iterator[Any]:
    """A TensorBoardLogger for --tensorboard (None without it); a missing extra is a one-sentence error (exit 1)."""
    if tensorboard_dir is None:
        yield None
        return
    from sumo_rail.learning.tensorboard_log import TensorBoardError, TensorBoardLogger

    try:
        logger = TensorBoardLogger(tensorboard_dir, prefix, run_folder)
    except TensorBoardError as error:
        raise click.ClickException(str(error)) from error
    try:
        yield logger
    except TensorBoardError as error:
        raise click.ClickException(str(error)) from error
    finally:
        logger.close()
