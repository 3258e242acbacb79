"""One command at a time per output: a lock file beside `--out`, made atomically, naming the pid that holds it."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import click

from .running import note_output


def lock_path(out: Path) -> Path:
    """The lock of output `out` (a file or a run folder): a hidden file beside it, `.NAME.lock`."""
    return out.parent / f".{out.name}.lock"


def lock_output(out: Path, option: str = "--out") -> None:
    """Hold `out` (given by `option`) for this command until its click context closes (whatever way it ends); a live
    other process holding it is one sentence (exit 1), a lock left by a process that is gone is taken over."""
    lock = lock_path(out.absolute())
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)  # a run folder's parent, made after its checks passed
    except OSError:
        return  # nothing can be written there; the output's own check says so
    for _ in range(2):
        try:
            _create(lock)
        except FileExistsError:
            holder = _holder(lock)
            if holder is not None and _alive(holder):
                raise click.ClickException(f"{out} is being written by another sumo-rail command (pid {holder}); "
                                           f"wait for it to end or choose another {option}") from None
            with contextlib.suppress(FileNotFoundError):
                lock.unlink()  # its holder is gone (killed): take it over
            continue
        except OSError:
            return  # a read-only place: the output's own check refuses it
        context = click.get_current_context(silent=True)
        if context is not None:
            context.call_on_close(lambda: _release(lock))
        note_output(out)  # a stop names it: written or not
        return
    raise click.ClickException(f"{out} is being written by another sumo-rail command; choose another {option}")


def _create(lock: Path) -> None:
    """Make `lock` holding this process's pid, atomically with its content (FileExistsError if it exists): the pid
    is written to a private file first, which is then linked to the lock's name (O_EXCL's guarantee, with content)."""
    private = lock.with_name(f"{lock.name}.{os.getpid()}")
    descriptor = os.open(private, os.O_CREAT | os.O_TRUNC | os.O_WRONLY, 0o644)
    try:
        with os.fdopen(descriptor, "w") as file:
            file.write(f"{os.getpid()}\n")
        os.link(private, lock)
    finally:
        private.unlink()


def _holder(lock: Path) -> int | None:
    """The pid written in `lock` (None when it is unreadable or half-written)."""
    try:
        return int(lock.read_text())
    except (OSError, ValueError):
        return None


def _alive(pid: int) -> bool:
    """Whether process `pid` exists."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _release(lock: Path) -> None:
    """Remove `lock` if this process still holds it."""
    if _holder(lock) == os.getpid():
        with contextlib.suppress(FileNotFoundError):
            lock.unlink()
