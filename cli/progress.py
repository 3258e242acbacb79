"""Progress output that fits where it goes: a live tqdm bar on a terminal, plain lines otherwise.

A bar redraws itself with carriage returns, which a file or a CI log keeps as one endless line; there a
`PlainProgress` writes one line every `interval_s` seconds (and a last one when done) instead.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from types import TracebackType
from typing import IO, Any, Self

from tqdm import tqdm

PLAIN_INTERVAL_S = 10.0
"""Seconds between two progress lines when stderr is not a terminal [s]."""


class PlainProgress:
    """The part of tqdm's interface the commands use (update, set_postfix, write, unit, close, context
    manager), writing "DESCRIPTION: N/TOTAL UNITs (P%), R UNIT/s, elapsed E s, K=V ..." lines to `stream`
    at most every `interval_s` seconds [s]; `clock` gives seconds (time.monotonic)."""

    def __init__(self, total: int, description: str, unit: str = "it", stream: IO[str] | None = None,
                 interval_s: float = PLAIN_INTERVAL_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.total = total
        self.description = description
        self.unit = unit
        self.n = self._initial = 0
        self._stream = stream if stream is not None else sys.stderr
        self._interval_s = interval_s
        self._clock = clock
        self._start = self._last = clock()
        self._postfix: dict[str, Any] = {}
        self._closed = False
        self._printed_n: int | None = None

    def update(self, n: int = 1) -> None:
        """Count `n` more units; print a line when `interval_s` has passed since the last one."""
        self.n += n
        if self._clock() - self._last >= self._interval_s:
            self._print()

    def start_at(self, done: int, restart_clock: bool = True) -> None:
        """Start counting from `done` units (a resumed run's steps done before): the count, and the rate and elapsed
        time from now on (from the start without `restart_clock`), are those of this run."""
        self.n = self._initial = done
        if restart_clock:
            self._start = self._last = self._clock()

    def set_postfix(self, **values: Any) -> None:
        """Values shown at the end of the next line."""
        self._postfix = values

    def write(self, text: str) -> None:
        """A message line of its own."""
        print(text, file=self._stream, flush=True)

    def close(self) -> None:
        """Print the final count (once), unless nothing was counted or printed (a command that stops on its inputs
        says why, without a "0/N" line before)."""
        if not self._closed:
            self._closed = True
            if self._printed_n != self.n and (self.n > self._initial or self._printed_n is not None):
                self._print()

    def _print(self) -> None:
        now = self._clock()
        elapsed = now - self._start
        rate = f"{(self.n - self._initial) / elapsed:.2f} {self.unit}/s" if elapsed > 0 else f"? {self.unit}/s"
        share = f" ({100.0 * self.n / self.total:.0f}%)" if self.total else ""
        extra = "".join(f", {key}={value}" for key, value in self._postfix.items())
        print(f"{self.description}: {self.n}/{self.total} {self.unit}s{share}, {rate}, elapsed {elapsed:.0f} s{extra}",
              file=self._stream, flush=True)
        self._last, self._printed_n = now, self.n

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def progress(total: int, description: str, unit: str = "episode", stream: IO[str] | None = None) -> Any:
    """A tqdm bar when `stream` (default stderr) is a terminal, else a `PlainProgress`."""
    stream = stream if stream is not None else sys.stderr
    if _is_terminal(stream):
        return tqdm(total=total, desc=description, unit=unit, dynamic_ncols=True, file=stream)
    return PlainProgress(total, description, unit, stream)


def start_at(bar: Any, done: int, restart_clock: bool = True) -> None:
    """Make `bar` (a tqdm bar or a `PlainProgress`) count from `done` units: a resumed run's bar starts where its
    run stopped, and its rate counts this run's units alone, over the time from now (from the bar's start without
    `restart_clock`: a run that learns how much was done only once its first new step is done)."""
    if isinstance(bar, PlainProgress):
        bar.start_at(done, restart_clock)
        return
    bar.n = bar.last_print_n = bar.initial = done
    if restart_clock:
        bar.start_t = bar.last_print_t = bar._time()  # noqa: SLF001 - tqdm keeps its clock private
    bar.refresh()


def advance_to(bar: Any, done: int) -> None:
    """Move `bar` (a tqdm bar or a `PlainProgress`) on to `done` units, e.g. after a resumed run's first step."""
    if done > bar.n:
        bar.update(done - bar.n)


def complete(bar: Any) -> None:
    """Move `bar` to its total: the work is done (whatever fewer units were counted: egos that sat out, steps done
    before a resume)."""
    advance_to(bar, bar.total)


def _is_terminal(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
