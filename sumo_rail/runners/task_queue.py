"""What every rollout backend shares: its errors and the bookkeeping of one `run` (which tasks wait, how often each
was tried, the results in task order)."""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from typing import Any


class BackendError(RuntimeError):
    """The backend could not complete the tasks (one-sentence message)."""


class TaskError(BackendError):
    """A task raised an exception in a worker; message names the task index and the worker's exception type and
    message. Not retried (it would fail again)."""

    def __init__(self, index: int, raised: str, detail: str) -> None:
        super().__init__(f"task {index} raised {raised}: {detail}")
        self.raised = raised
        """The type name of the task's exception."""
        self.detail = detail
        """The task's exception's message."""


class TaskQueue:
    """One `run` of `count` tasks: a task handed out counts as an attempt, one that got no result goes first in the
    queue again while attempts remain, and each result is stored in task order and passed to `on_result`."""

    def __init__(self, count: int, max_attempts: int, on_result: Callable[[int, Any], None] | None,
                 log: logging.Logger) -> None:
        self.results: list[Any] = [None] * count
        self.remaining = count
        """Tasks without a result yet."""
        self._pending = deque(range(count))
        self._attempts = [0] * count
        self._max_attempts = max_attempts
        self._failed_starts = 0
        """Workers that died before they ran a task."""
        self._on_result = on_result
        self._log = log

    def waiting(self) -> bool:
        """Whether a task waits to be handed out."""
        return bool(self._pending)

    def next(self) -> int:
        """The index of the next waiting task, counted as one more attempt of it."""
        index = self._pending.popleft()
        self._attempts[index] += 1
        return index

    def retry(self, index: int | None, cause: str) -> None:
        """Queue task `index` again after a worker got no result because of `cause`, if attempts remain (None: the
        worker died before it ran a task; the run fails when as many workers as a task's attempts died so)."""
        if index is None:
            self._failed_starts += 1
            if self._failed_starts >= self._max_attempts:
                raise BackendError(f"a worker process could not start in {self._failed_starts} attempts (last: "
                                   f"{cause})")
            self._log.warning("a worker died while it started (%s); starting another", cause)
            return
        if self._attempts[index] >= self._max_attempts:
            raise BackendError(f"task {index} got no result in {self._attempts[index]} attempts (last: {cause})")
        self._log.warning("task %d: %s; retrying it (attempt %d of %d)", index, cause, self._attempts[index] + 1,
                          self._max_attempts)
        self._pending.appendleft(index)

    def done(self, index: int, result: Any) -> None:
        """Store task `index`'s result and pass it to `on_result`."""
        self.results[index] = result
        self.remaining -= 1
        if self._on_result is not None:
            self._on_result(index, result)
