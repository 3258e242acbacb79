"""Rollout backends: run picklable tasks in the calling process or on a crash-tolerant pool of worker processes.

libsumo allows one simulation per process, so parallel episodes need one long-lived worker process each, owning a
`WorkerContext` (and through it one `HighwayEnv`) for its whole life. `ProcessPoolBackend` spawns the workers on
its first `run`, hands each idle worker the next pending task, replaces a worker that dies or exceeds the task
timeout and resubmits only the task it was running, and returns the results in task order.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import threading
import time
import traceback
import weakref
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from types import TracebackType
from typing import Any, Protocol, Self

from sumo_rail.config import Config
from sumo_rail.runners.spawning import die_with_parent, ignore_stop_signals, start_shielded
from sumo_rail.runners.task_queue import BackendError as BackendError  # importable from here, as before
from sumo_rail.runners.task_queue import TaskError as TaskError
from sumo_rail.runners.task_queue import TaskQueue
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.parallel_env import ParallelHighwayEnv

log = logging.getLogger(__name__)

_STOP_TIMEOUT_S = 2.0
"""How long `close` waits for workers to stop by themselves before killing them [s]."""
_EXIT_TIMEOUT_S = 1.0
"""How long a worker whose pipe reached end-of-file may take to exit before it is killed [s]."""
_READY = "ready"
"""What a worker sends once it has started, before its first task."""
_STOP = None
"""What the parent sends to ask an idle worker to stop."""
_GONE = object()
"""What `_receive` returns when a worker exited without sending a message."""


class Task(Protocol):
    """A picklable unit of work; must be a top-level class so spawned workers can unpickle it."""

    def run(self, context: WorkerContext) -> Any: ...


class WorkerContext:
    """Per-process state of a worker: caches one env, a HighwayEnv per Config or a ParallelHighwayEnv per Config
    and number of egos (libsumo allows one simulation per process, so when a task asks for another env the old one
    is closed first)."""

    def __init__(self, render_mode: str | None = None, gui_delay_ms: float = 100.0) -> None:
        self._render_mode = render_mode
        self._gui_delay_ms = gui_delay_ms
        self._key: Hashable = None
        self._env: HighwayEnv | ParallelHighwayEnv | None = None

    @property
    def render_mode(self) -> str | None:
        """How the envs of this worker render ("human": sumo-gui), for `custom_env`'s makers."""
        return self._render_mode

    @property
    def gui_delay_ms(self) -> float:
        """Wall-clock milliseconds per SUMO step in sumo-gui."""
        return self._gui_delay_ms

    def env(self, config: Config) -> HighwayEnv:
        """The single-ego env of `config`, created on first use and kept for later tasks with an equal config."""
        if self._env is None or self._key != (config, None):
            self.close()
            self._env = HighwayEnv(config, render_mode=self._render_mode, transport="libsumo",
                                   gui_delay_ms=self._gui_delay_ms)
            self._key = (config, None)
        assert isinstance(self._env, HighwayEnv)
        return self._env

    def parallel_env(self, config: Config, egos: int) -> ParallelHighwayEnv:
        """The env of `egos` egos on `config`'s road, created on first use and kept like `env`."""
        if self._env is None or self._key != (config, egos):
            self.close()
            self._env = ParallelHighwayEnv(egos, config, transport="libsumo")
            self._key = (config, egos)
        assert isinstance(self._env, ParallelHighwayEnv)
        return self._env

    def custom_env(self, key: Hashable, create: Callable[[], Any]) -> Any:
        """An env of another kind (a recorded scene's), made by `create` on first use and kept like `env` for later
        tasks with an equal `key`."""
        if self._env is None or self._key != key:
            self.close()
            self._env = create()
            self._key = key
        return self._env

    def close(self) -> None:
        """Close the cached env, if any."""
        if self._env is not None:
            env, self._env, self._key = self._env, None, None
            env.close()


class RolloutBackend(Protocol):
    """Runs tasks and returns their results in task order; usable as a context manager that closes it."""

    workers: int

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        """Run every task exactly once (per successful completion); results in task order, whatever order they
        finished in; on_result(index, result) is called in the calling process as each result arrives (for
        progress bars)."""
        ...

    def close(self) -> None:
        """Release the backend's resources; idempotent."""
        ...

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


class SerialBackend(RolloutBackend):
    """Runs tasks one after the other in the calling process, with its own `WorkerContext` (whose envs use
    `render_mode`, e.g. "human" to watch episodes in sumo-gui, `gui_delay_ms` [ms] per SUMO step apart)."""

    def __init__(self, render_mode: str | None = None, gui_delay_ms: float = 100.0) -> None:
        self.workers = 1
        self._context = WorkerContext(render_mode, gui_delay_ms)
        self._closed = False

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        if self._closed:
            raise BackendError("the serial backend is closed")
        results = []
        for index, task in enumerate(tasks):
            try:
                result = task.run(self._context)
            except Exception as exc:
                raise TaskError(index, type(exc).__name__, str(exc)) from exc
            results.append(result)
            if on_result is not None:
                on_result(index, result)
        return results

    def close(self) -> None:
        self._closed = True
        self._context.close()


@dataclass
class _Worker:
    """The parent's view of one worker process."""

    process: BaseProcess
    conn: Connection
    ready: bool = False
    """The worker has started and can take tasks."""
    task: int | None = None
    """Index of the task it is running."""
    deadline: float | None = None
    """`time.monotonic()` after which its task counts as timed out."""

    def waitables(self) -> list[Any]:
        return [self.conn, self.process.sentinel]


def check_pool_settings(workers: int, task_timeout_s: float | None, max_attempts: int) -> None:
    """Raise ValueError unless workers >= 1, task_timeout_s is None or > 0 [s], and max_attempts >= 1."""
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if task_timeout_s is not None and task_timeout_s <= 0:
        raise ValueError(f"task_timeout_s must be positive or None, got {task_timeout_s}")
    if max_attempts < 1:
        raise ValueError(f"max_attempts must be at least 1, got {max_attempts}")


class ProcessPoolBackend(RolloutBackend):
    """Long-lived spawned worker processes, one task at a time each; a worker that dies or times out is replaced
    and only its task is resubmitted, at most `max_attempts` times in all."""

    def __init__(self, workers: int, task_timeout_s: float | None = None, max_attempts: int = 3) -> None:
        check_pool_settings(workers, task_timeout_s, max_attempts)
        self.workers = workers
        self.task_timeout_s = task_timeout_s
        self.max_attempts = max_attempts
        self._context = multiprocessing.get_context("spawn")
        self._pool: list[_Worker] = []
        # Holds the list, not self, so that garbage collection or interpreter exit stops the workers too.
        self._finalizer = weakref.finalize(self, _stop_workers, self._pool)

    @property
    def pids(self) -> list[int]:
        """Process ids of the current workers (empty before the first run and after close)."""
        return [worker.process.pid for worker in self._pool if worker.process.pid is not None]

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        if not self._finalizer.alive:
            raise BackendError("the process pool backend is closed")
        queue = TaskQueue(len(tasks), self.max_attempts, on_result, log)
        try:
            while queue.remaining:
                self._replace_dead_idle_workers()
                for worker in self._pool:
                    if queue.waiting() and worker.ready and worker.task is None:
                        index = queue.next()
                        self._assign(worker, index, tasks[index])
                active = [worker for worker in self._pool if worker.task is not None or not worker.ready]
                events = set(wait([w for worker in active for w in worker.waitables()], self._wait_timeout(active)))
                for worker in active:
                    if events.isdisjoint(worker.waitables()):
                        if worker.deadline is not None and time.monotonic() > worker.deadline:
                            self._retire(worker, 0.0)
                            queue.retry(worker.task, f"timed out after {self.task_timeout_s} s")
                        continue
                    message = self._receive(worker)
                    if message is _GONE:
                        code = self._retire(worker, _EXIT_TIMEOUT_S)
                        queue.retry(worker.task, f"worker exited with code {code}")
                    elif not worker.ready:
                        worker.ready = True
                    else:
                        finished, worker.task, worker.deadline = worker.task, None, None
                        assert finished is not None  # a ready worker answers only the task it was given
                        ok, payload = message
                        if not ok:
                            type_name, text, trace = payload
                            log.debug("task %d raised in worker %d:\n%s", finished, worker.process.pid, trace)
                            raise TaskError(finished, type_name, text)
                        queue.done(finished, payload)
        finally:
            # Only after an exception: tasks still running must not deliver their results to the next run.
            for worker in [worker for worker in self._pool if worker.task is not None]:
                self._retire(worker, 0.0)
        return queue.results

    def close(self) -> None:
        self._finalizer()

    def _start_worker(self) -> None:
        parent_conn, child_conn = self._context.Pipe(duplex=True)
        process = self._context.Process(target=_worker_main, args=(child_conn,), name="sumo-rail-worker", daemon=True)
        start_shielded(process)  # a Ctrl-C while it imports must not kill it: the parent decides
        child_conn.close()
        self._pool.append(_Worker(process, parent_conn))

    def _replace_dead_idle_workers(self) -> None:
        for worker in [worker for worker in self._pool if worker.ready and worker.task is None]:
            if not worker.process.is_alive():
                log.warning("idle worker %d exited with code %s; starting a new one", worker.process.pid,
                            self._retire(worker, 0.0))
        while len(self._pool) < self.workers:
            self._start_worker()

    def _assign(self, worker: _Worker, index: int, task: Task) -> None:
        try:
            data = pickle.dumps(task, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as exc:
            raise BackendError(f"task {index} cannot be sent to a worker ({type(exc).__name__}: {exc})") from exc
        worker.task = index
        worker.deadline = None if self.task_timeout_s is None else time.monotonic() + self.task_timeout_s
        try:
            worker.conn.send_bytes(data)
        except OSError:
            pass  # The worker has died; its sentinel reports it and the task is retried.

    def _wait_timeout(self, active: list[_Worker]) -> float | None:
        deadlines = [worker.deadline for worker in active if worker.deadline is not None]
        return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None

    @staticmethod
    def _receive(worker: _Worker) -> Any:
        """The worker's next message, or `_GONE` if its process has exited without sending one."""
        try:
            if worker.conn.poll():
                return worker.conn.recv()
        except (EOFError, OSError):
            pass
        return _GONE

    def _retire(self, worker: _Worker, timeout_s: float) -> int | None:
        """Remove `worker` from the pool, killing it unless it exits within `timeout_s`; returns its exit code."""
        self._pool.remove(worker)
        return _end_worker(worker, timeout_s)


def _end_worker(worker: _Worker, timeout_s: float) -> int | None:
    """Wait up to `timeout_s` for `worker` to exit, then kill it, and release its pipe; returns its exit code."""
    process = worker.process
    process.join(timeout_s)
    if process.is_alive():
        process.kill()
        process.join()
    worker.conn.close()
    exit_code = process.exitcode
    process.close()
    return exit_code


def _stop_workers(pool: list[_Worker]) -> None:
    """Ask every worker to stop, give them `_STOP_TIMEOUT_S` in all, then kill the rest."""
    for worker in pool:
        try:
            worker.conn.send_bytes(pickle.dumps(_STOP))
        except OSError:
            pass  # Already gone.
    deadline = time.monotonic() + _STOP_TIMEOUT_S
    for worker in pool:
        _end_worker(worker, max(0.0, deadline - time.monotonic()))
    pool.clear()


def _worker_main(conn: Connection) -> None:
    """Entry point of a worker process: run the tasks received on `conn` until told to stop or the parent is gone."""
    ignore_stop_signals()  # Ctrl-C and a SIGTERM reach the whole process group: the parent decides
    die_with_parent()
    threading.Thread(target=_exit_when_parent_dies, name="parent-watchdog", daemon=True).start()
    context = WorkerContext()
    try:
        if not _reply(conn, _READY):
            return
        while True:
            try:
                data = conn.recv_bytes()
            except (EOFError, OSError):
                return
            try:
                task = pickle.loads(data)
                if task is _STOP:
                    return
                reply = (True, task.run(context))
            except Exception as exc:
                reply = (False, _describe(exc))
            if not _reply(conn, reply):
                return
    finally:
        context.close()
        conn.close()


def _exit_when_parent_dies() -> None:
    """Exit the worker as soon as its parent is gone, even in the middle of a task, so that it is never orphaned."""
    parent = multiprocessing.parent_process()
    if parent is not None:
        wait([parent.sentinel])
        os._exit(1)


def _reply(conn: Connection, message: Any) -> bool:
    """Send `message` to the parent (an error reply if it cannot be pickled); False if the parent is gone."""
    try:
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        data = pickle.dumps((False, _describe(exc)), protocol=pickle.HIGHEST_PROTOCOL)
    try:
        conn.send_bytes(data)
    except OSError:
        return False
    return True


def _describe(exc: Exception) -> tuple[str, str, str]:
    """Type name, message and formatted traceback of `exc`, for the parent."""
    return type(exc).__name__, str(exc), "".join(traceback.format_exception(exc))
