"""Ray backend: the interface of `sumo_rail.runners.backends` on Ray actors, locally or on a Ray cluster.

Each actor owns one `WorkerContext` (so one SUMO: libsumo allows one simulation per process) for its whole life,
reserves one CPU and runs one task at a time. An actor that dies (process killed, node removed) or exceeds the task
timeout is replaced and only its unfinished task is resubmitted, at most `max_attempts` times in all. Ray is
imported only when a `RayBackend` is made, so it stays an optional dependency. A private local Ray ends with this
process however it ends, SIGKILL included (`ray_reaper`); a cluster's Ray ends a driver's actors with its job.
"""

from __future__ import annotations

import contextlib
import logging
import os
import secrets
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from sumo_rail.runners import ray_reaper
from sumo_rail.runners.backends import RolloutBackend, Task, WorkerContext, check_pool_settings
from sumo_rail.runners.task_queue import BackendError, TaskError, TaskQueue

log = logging.getLogger(__name__)

INSTALL_HINT = "the ray backend needs Ray: pip install 'sumo-rail[ray]'"


class _Actor:
    """Body of one Ray actor: runs tasks with a `WorkerContext` kept for the actor's life."""

    def __init__(self) -> None:
        self._context = WorkerContext()

    def pid(self) -> int:
        """Process id of the actor; its reply also tells the driver that the actor has started."""
        return os.getpid()

    def run(self, task: Task) -> Any:
        return task.run(self._context)


@dataclass
class _Slot:
    """The driver's view of one actor."""

    actor: Any
    """Its Ray actor handle."""
    started: Any
    """ObjectRef of its `pid()` call, answered once the actor runs."""
    pid: int | None = None
    """Its process id, once started."""
    task: int | None = None
    """Index of the task it is running."""
    ref: Any = None
    """ObjectRef of that task's result."""
    deadline: float | None = None
    """`time.monotonic()` after which its task counts as timed out."""

    def awaited(self) -> Any:
        """The ObjectRef the driver waits on for this actor, or None if it is idle."""
        return self.started if self.pid is None else self.ref


class RayBackend(RolloutBackend):
    """`workers` Ray actors of one CPU each, one task at a time each; `address=None` starts a private local Ray
    with `workers` CPUs, "auto" or "HOST:PORT" connects to a running cluster. If this process is already
    connected to Ray, that connection is used and left open by `close`."""

    def __init__(self, workers: int, address: str | None = None, task_timeout_s: float | None = None,
                 max_attempts: int = 3) -> None:
        check_pool_settings(workers, task_timeout_s, max_attempts)
        self.workers = workers
        self.address = address
        self.task_timeout_s = task_timeout_s
        self.max_attempts = max_attempts
        self._ray = _import_ray()
        self._actor_class = self._ray.remote(num_cpus=1, max_restarts=0)(_Actor)
        self._slots: list[_Slot] = []
        self._owns_ray = False
        self._reaper: subprocess.Popen[bytes] | None = None
        """`ray_reaper` beside a private local Ray this backend started (on Linux)."""
        self._start_failures = 0
        """Actors that died before starting since one last started."""
        self._closed = False

    @property
    def pids(self) -> list[int]:
        """Process ids of the started actors (empty before the first run and after close)."""
        return [slot.pid for slot in self._slots if slot.pid is not None]

    def run(self, tasks: Sequence[Task], on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        if self._closed:
            raise BackendError("the ray backend is closed")
        ray = self._ray
        self._connect()
        queue = TaskQueue(len(tasks), self.max_attempts, on_result, log)
        try:
            while queue.remaining:
                while len(self._slots) < self.workers:
                    actor = self._actor_class.remote()
                    self._slots.append(_Slot(actor, actor.pid.remote()))
                for slot in self._slots:
                    if queue.waiting() and slot.pid is not None and slot.task is None:
                        index = queue.next()
                        self._assign(slot, index, tasks[index])
                awaited = {slot.awaited(): slot for slot in self._slots if slot.awaited() is not None}
                done, _ = ray.wait(list(awaited), num_returns=1, timeout=self._wait_timeout())
                for ref in done:
                    slot = awaited[ref]
                    if slot.pid is None:
                        self._started(slot)
                        continue
                    finished, slot.task, slot.ref, slot.deadline = slot.task, None, None, None
                    assert finished is not None  # a started actor's awaited ref is its task's result
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayTaskError as error:
                        raised, _, detail = _describe(error).partition(": ")
                        raise TaskError(finished, raised, detail) from error
                    except ray.exceptions.RayError as error:
                        self._retire(slot)
                        queue.retry(finished, f"Ray worker {slot.pid} was lost ({_describe(error)})")
                        continue
                    queue.done(finished, result)
                now = time.monotonic()
                for slot in [s for s in self._slots if s.deadline is not None and s.deadline < now]:
                    timed_out = slot.task
                    self._retire(slot)
                    queue.retry(timed_out, f"timed out after {self.task_timeout_s} s")
        finally:
            # Only after an exception: tasks still running must not hold up or leak into the next run.
            for slot in [slot for slot in self._slots if slot.task is not None]:
                self._retire(slot)
        return queue.results

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._ray.is_initialized():
            for slot in list(self._slots):
                self._retire(slot)
            if self._owns_ray:
                self._ray.shutdown()
        self._end_reaper()
        self._slots.clear()

    def _connect(self) -> None:
        """Start or join Ray unless this process is connected already."""
        ray = self._ray
        if ray.is_initialized():
            return
        try:
            if self.address is None:
                with self._reaped():
                    ray.init(address="local", num_cpus=self.workers, include_dashboard=False, log_to_driver=False,
                             logging_level=logging.WARNING)
            else:
                _check_reachable(self.address)
                ray.init(address=self.address, log_to_driver=False, logging_level=logging.WARNING)
        except Exception as error:
            self._end_reaper()  # and with it what the failed start left behind
            where = "start a local Ray" if self.address is None else f"connect to the Ray cluster at {self.address}"
            raise BackendError(f"could not {where}: {_describe(error)}") from error
        self._owns_ray = True
        cpus = ray.cluster_resources().get("CPU", 0.0)
        if cpus < self.workers:
            log.warning("the Ray cluster has %g CPUs for %d workers; the other workers wait for free CPUs", cpus,
                        self.workers)

    @contextlib.contextmanager
    def _reaped(self) -> Iterator[None]:
        """On Linux, start `ray_reaper` and mark the processes started in the block (a local Ray's) for it: they end
        when this process does, however it ends, or when the backend closes."""
        if not sys.platform.startswith("linux"):
            yield
            return
        token = f"{os.getpid()}-{secrets.token_hex(8)}"
        self._reaper = subprocess.Popen([sys.executable, "-I", ray_reaper.__file__, token], stdin=subprocess.PIPE,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        previous = os.environ.get(ray_reaper.MARK)
        os.environ[ray_reaper.MARK] = token  # inherited by Ray's processes, and by theirs (the workers)
        try:
            yield
        finally:
            if previous is None:
                del os.environ[ray_reaper.MARK]
            else:
                os.environ[ray_reaper.MARK] = previous

    def _end_reaper(self) -> None:
        """Let `ray_reaper` kill what is left of the local Ray (nothing after a clean shutdown) and wait for it."""
        if self._reaper is None:
            return
        reaper, self._reaper = self._reaper, None
        if reaper.stdin is not None:
            reaper.stdin.close()
        try:
            reaper.wait(timeout=30)
        except subprocess.TimeoutExpired:
            reaper.kill()
            reaper.wait()

    def _started(self, slot: _Slot) -> None:
        """Record that `slot`'s actor has started, or drop it (to be replaced) if it died first; gives up when its
        constructor failed or more than `max_attempts * workers` actors in a row died before starting."""
        ray = self._ray
        try:
            slot.pid = ray.get(slot.started)
        except ray.exceptions.RayActorError as error:
            self._retire(slot)
            self._start_failures += 1
            if error.actor_init_failed or self._start_failures > self.max_attempts * self.workers:
                raise BackendError(f"Ray workers could not start (last: {_describe(error)})") from error
            log.warning("a Ray worker died while starting (%s); starting a new one", _describe(error))
        else:
            self._start_failures = 0

    def _assign(self, slot: _Slot, index: int, task: Task) -> None:
        slot.task = index
        slot.deadline = None if self.task_timeout_s is None else time.monotonic() + self.task_timeout_s
        try:
            slot.ref = slot.actor.run.remote(task)
        except Exception as error:
            raise BackendError(f"task {index} cannot be sent to a Ray worker ({_describe(error)})") from error

    def _wait_timeout(self) -> float | None:
        deadlines = [slot.deadline for slot in self._slots if slot.deadline is not None]
        return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None

    def _retire(self, slot: _Slot) -> None:
        """Remove `slot` and kill its actor process (and with it the actor's SUMO)."""
        self._slots.remove(slot)
        try:
            self._ray.kill(slot.actor, no_restart=True)
        except self._ray.exceptions.RayError:
            pass  # Its creation was cancelled: there is no process to kill.


def _check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Fail fast when HOST:PORT accepts no connection (Ray itself retries for many minutes); "auto" passes."""
    host, separator, port = address.rpartition(":")
    if not separator or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except OSError as error:
        raise ConnectionError(f"nothing accepts connections at {address} ({error.strerror or error})") from error


def _import_ray() -> ModuleType:
    try:
        import ray
    except ImportError as error:
        raise BackendError(INSTALL_HINT) from error
    return ray


def _describe(error: BaseException) -> str:
    """'TypeName: first line of the message'; for a task's own exception (wrapped by Ray) its original type."""
    cause = getattr(error, "cause", None)
    if isinstance(cause, BaseException):
        error = cause
    lines = str(error).strip().splitlines()
    return f"{type(error).__name__}: {lines[0]}" if lines else type(error).__name__
