"""Rollout backends: task order, crash and timeout recovery, task errors, shutdown and SUMO reproducibility.

Task classes are top-level so that spawned workers can unpickle them.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from sumo_rail.config import Config
from sumo_rail.runners.backends import BackendError, ProcessPoolBackend, SerialBackend, TaskError, WorkerContext
from sumo_rail.runners.factory import make_backend
from sumo_rail.runners.task_queue import TaskQueue
from sumo_rail.sim.actions import Action


@dataclass(frozen=True)
class Square:
    """Returns (value, value**2) after sleeping; touches `started_dir / <pid>` when it starts, if given."""

    value: int
    sleep_s: float = 0.0
    started_dir: Path | None = None

    def run(self, context: WorkerContext) -> tuple[int, int]:
        if self.started_dir is not None:
            (self.started_dir / str(os.getpid())).touch()
        time.sleep(self.sleep_s)
        return self.value, self.value**2


@dataclass(frozen=True)
class Gated:
    """Writes its pid into `started` (if given; atomically) when it starts, waits until the file `gate` exists (at most
    `patience_s` [s], so that a test whose gate never opens fails on its assertions rather than hanging), then
    returns (value, value**2)."""

    value: int
    gate: Path
    started: Path | None = None
    patience_s: float = 30.0

    def run(self, context: WorkerContext) -> tuple[int, int]:
        if self.started is not None:
            staged = self.started.with_name(self.started.name + ".tmp")
            staged.write_text(str(os.getpid()))
            staged.replace(self.started)
        deadline = time.monotonic() + self.patience_s
        while not self.gate.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        return self.value, self.value**2


@dataclass(frozen=True)
class DieOnce:
    """SIGKILLs its own worker the first time (writing the pid to `marker`), then returns its pid."""

    marker: Path

    def run(self, context: WorkerContext) -> int:
        if not self.marker.exists():
            self.marker.write_text(str(os.getpid()))
            os.kill(os.getpid(), signal.SIGKILL)
        return os.getpid()


@dataclass(frozen=True)
class HangOnce:
    """Sleeps 60 s the first time (writing its pid to `marker`), then returns (`value`, its pid)."""

    marker: Path
    value: int

    def run(self, context: WorkerContext) -> tuple[int, int]:
        if not self.marker.exists():
            self.marker.write_text(str(os.getpid()))
            time.sleep(60.0)
        return self.value, os.getpid()


@dataclass(frozen=True)
class Rendezvous:
    """Touches `directory / <pid>` and waits (up to 20 s) until `parties` workers have done so; returns the pid."""

    directory: Path
    parties: int

    def run(self, context: WorkerContext) -> int:
        (self.directory / str(os.getpid())).touch()
        deadline = time.monotonic() + 20.0
        while len(list(self.directory.iterdir())) < self.parties and time.monotonic() < deadline:
            time.sleep(0.01)
        return os.getpid()


class AlwaysDie:
    """Kills its own worker every time."""

    def run(self, context: WorkerContext) -> None:
        os.kill(os.getpid(), signal.SIGKILL)


class Fail:
    """Raises ValueError."""

    def run(self, context: WorkerContext) -> None:
        raise ValueError("bad value 7")


@dataclass(frozen=True)
class Episode:
    """One episode of constant KEEP actions: (sum of rewards, number of decisions)."""

    config: Config
    seed: int

    def run(self, context: WorkerContext) -> tuple[float, int]:
        env = context.env(self.config)
        env.reset(seed=self.seed)
        total, steps, done = 0.0, 0, False
        while not done:
            _, reward, terminated, truncated, _ = env.step(Action.KEEP)
            total += reward
            steps += 1
            done = terminated or truncated
        return total, steps


def squares(count: int, step_s: float = 0.01) -> list[Square]:
    """Tasks whose sleeps shrink with the index, so that parallel workers finish them out of task order."""
    return [Square(value, sleep_s=step_s * (count - value)) for value in range(count)]


def warm_up(pool: ProcessPoolBackend, directory: Path) -> set[int]:
    """Start every worker of `pool` and make sure each has run a task; returns their pids."""
    directory.mkdir()
    pids = set(pool.run([Rendezvous(directory, pool.workers)] * pool.workers))
    assert pids == set(pool.pids)
    return pids


def expected(tasks: list[Square]) -> list[tuple[int, int]]:
    return [(task.value, task.value**2) for task in tasks]


def assert_no_process(pids: list[int]) -> None:
    for pid in pids:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


@pytest.fixture
def pool():
    backend = ProcessPoolBackend(2)
    yield backend
    backend.close()


def test_serial_and_process_pool_return_results_in_task_order(tmp_path):
    """Each even task waits until the next task's result has arrived, so two workers finish them in the order
    1, 0, 3, 2, 5, 4 whatever the machine's speed; the results come back in task order all the same."""
    arrivals: dict[str, list[int]] = {"serial": [], "process": []}

    def arrived(index: int, result: Any) -> None:
        arrivals["process"].append(index)
        (tmp_path / f"arrived_{index}").touch()

    gated = [Gated(value, tmp_path / f"arrived_{value + 1}") if value % 2 == 0 else Square(value) for value in range(6)]
    with SerialBackend() as serial, ProcessPoolBackend(2) as pool:
        serial_results = serial.run(squares(6), lambda index, result: arrivals["serial"].append(index))
        pool_results = pool.run(gated, arrived)
    assert serial_results == pool_results == expected(squares(6))
    assert arrivals["serial"] == list(range(6))
    assert arrivals["process"] == [1, 0, 3, 2, 5, 4]


def test_workers_are_reused_across_runs(pool):
    assert pool.pids == []
    pool.run(squares(2))
    pids = pool.pids
    assert len(pids) == 2
    assert pool.run(squares(4)) == expected(squares(4))
    assert pool.pids == pids


def test_a_worker_killed_by_its_task_is_replaced_and_only_that_task_rerun(pool, tmp_path, caplog):
    tasks = [Square(0, 0.1), DieOnce(tmp_path / "died"), Square(2, 0.1), Square(3)]
    first_pids = warm_up(pool, tmp_path / "warm")
    seen: list[int] = []
    results = pool.run(tasks, lambda index, result: seen.append(index))
    dead_pid = int((tmp_path / "died").read_text())
    assert dead_pid in first_pids
    assert results[1] != dead_pid and results[1] in pool.pids
    assert dead_pid not in pool.pids and len(set(pool.pids) - first_pids) == 1, "one new worker replaced it"
    assert results[:1] + results[2:] == [(0, 0), (2, 4), (3, 9)]
    assert sorted(seen) == [0, 1, 2, 3]
    assert "task 1: worker exited with code -9" in caplog.text


def test_a_worker_killed_from_outside_is_replaced_and_results_match(pool, tmp_path, caplog):
    started = tmp_path / "started"
    started.mkdir()
    tasks = [Square(value, sleep_s=0.3, started_dir=started) for value in range(6)]
    killed: list[int] = []

    def kill_first_busy_worker() -> None:
        deadline = time.monotonic() + 20.0
        while not any(started.iterdir()) and time.monotonic() < deadline:
            time.sleep(0.01)
        if not any(started.iterdir()):
            return  # the test fails below, saying so
        pid = int(next(started.iterdir()).name)
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    killer = threading.Thread(target=kill_first_busy_worker)
    killer.start()
    try:
        results = pool.run(tasks)
    finally:
        killer.join()
    assert killed, "no worker started a task within 20 s, so none was killed"
    assert results == expected(tasks)
    assert killed[0] not in pool.pids
    assert "worker exited with code -9" in caplog.text


def test_a_hanging_task_times_out_and_is_retried_on_a_fresh_worker(tmp_path, caplog):
    with ProcessPoolBackend(2, task_timeout_s=1.0) as pool:
        results = pool.run([Square(1), HangOnce(tmp_path / "hung", 5), Square(2)])
        hung_pid = int((tmp_path / "hung").read_text())
        assert hung_pid not in pool.pids  # the hanging worker was replaced...
        assert_no_process([hung_pid])  # ...and is gone, rather than left to finish its 60 s
    assert results[0] == (1, 1) and results[2] == (2, 4)
    assert results[1][0] == 5 and results[1][1] != hung_pid  # the retry's answer, from another worker
    assert "task 1: timed out after 1.0 s" in caplog.text


def test_a_task_that_always_kills_its_worker_fails_after_max_attempts_and_the_pool_stays_usable():
    with ProcessPoolBackend(2, max_attempts=2) as pool:
        message = r"task 1 got no result in 2 attempts \(last: worker exited with code -9\)"
        with pytest.raises(BackendError, match=message) as info:
            pool.run([Square(0), AlwaysDie(), Square(2, 0.5)])
        assert not isinstance(info.value, TaskError)
        assert pool.run(squares(3)) == expected(squares(3))


def test_serial_backend_passes_its_render_mode_to_the_env(small_config):
    with SerialBackend(render_mode="window") as serial, pytest.raises(TaskError, match="render_mode"):
        serial.run([Episode(small_config, 0)])


def test_a_task_exception_raises_task_error_and_no_result_leaks_into_the_next_run(pool):
    with pytest.raises(TaskError, match=r"task 1 raised ValueError: bad value 7"):
        pool.run([Square(100, 0.5), Fail()])
    assert pool.run(squares(4)) == expected(squares(4))


def test_serial_backend_wraps_task_exceptions():
    with SerialBackend() as serial, pytest.raises(TaskError, match=r"task 0 raised ValueError: bad value 7"):
        serial.run([Fail()])


def test_interrupt_during_a_run_propagates_and_the_pool_stays_usable(pool, tmp_path):
    def interrupt(index: int, result: Any) -> None:
        raise KeyboardInterrupt

    busy, release = tmp_path / "busy", tmp_path / "release"
    with pytest.raises(KeyboardInterrupt):  # task 0's result arrives once task 1 is running, and interrupts the run
        pool.run([Gated(0, gate=busy), Gated(7, gate=release, started=busy)], interrupt)
    abandoned = int(busy.read_text())
    release.touch()  # were the interrupted task still running, it would now answer (7, 49) into the next run
    assert pool.run(squares(2)) == expected(squares(2))
    assert abandoned not in pool.pids
    assert_no_process([abandoned])


def test_a_ctrl_c_while_a_worker_starts_does_not_kill_it():
    """Ctrl-C reaches the whole process group: a worker still importing must not die of it (a traceback on the
    terminal, a lost worker); the parent alone decides how a command stops."""
    with ProcessPoolBackend(1) as pool:
        pool._start_worker()
        os.kill(pool.pids[0], signal.SIGINT)  # it takes far longer to start than this
        worker = pool.pids
        assert pool.run(squares(2)) == expected(squares(2)) and pool.pids == worker


def test_a_worker_killed_while_it_starts_is_replaced(caplog):
    """kill -9 (the OOM killer, a user) of a worker still importing: another one is started and the results come,
    as for a worker killed in a task; a worker that dies at every start fails the run after max_attempts."""
    with ProcessPoolBackend(1) as pool:
        pool._start_worker()
        killed = pool.pids
        os.kill(killed[0], signal.SIGKILL)  # it takes far longer to start than this
        assert pool.run(squares(2)) == expected(squares(2)) and pool.pids != killed
    assert "a worker died while it started (worker exited with code -9); starting another" in caplog.text
    queue = TaskQueue(1, 2, None, logging.getLogger("test"))
    queue.retry(None, "worker exited with code 1")
    with pytest.raises(BackendError, match=r"^a worker process could not start in 2 attempts \(last: worker exited "
                                           r"with code 1\)$"):
        queue.retry(None, "worker exited with code 1")


def test_a_sigterm_to_a_starting_or_running_worker_does_not_kill_it():
    """GNU timeout and schedulers send SIGTERM to the whole process group: a worker ignores it as it ignores a
    Ctrl-C, from its start (still importing) on; the parent alone decides how a command stops."""
    with ProcessPoolBackend(1) as pool:
        pool._start_worker()
        os.kill(pool.pids[0], signal.SIGTERM)  # it takes far longer to start than this
        worker = pool.pids
        assert pool.run(squares(2)) == expected(squares(2)) and pool.pids == worker
        os.kill(worker[0], signal.SIGTERM)
        assert pool.run(squares(3)) == expected(squares(3)) and pool.pids == worker


def test_close_is_idempotent_and_leaves_no_worker_process():
    pool = ProcessPoolBackend(2)
    pool.run(squares(2))
    pids = pool.pids
    assert len(pids) == 2
    pool.close()
    pool.close()
    assert_no_process(pids)
    assert pool.pids == []
    with pytest.raises(BackendError, match="closed"):
        pool.run(squares(1))


def process_exited(pid: int) -> bool:
    """The process is gone or a zombie (a container's init may be slow to reap orphans)."""
    try:
        return "\tZ" in Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc")
def test_busy_workers_exit_when_their_parent_is_killed(tmp_path):
    started = tmp_path / "started"
    started.mkdir()
    script = textwrap.dedent(f"""
        import sys
        from pathlib import Path
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_backends import Square
        from sumo_rail.runners.backends import ProcessPoolBackend
        pool = ProcessPoolBackend(2)
        pool.run([Square(0), Square(1)])
        print(*pool.pids, flush=True)
        pool.run([Square(0, 60.0, Path({str(started)!r})), Square(1, 60.0, Path({str(started)!r}))])
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(pid) for pid in parent.stdout.readline().split()]
        assert len(pids) == 2
        deadline = time.monotonic() + 30.0
        while len(list(started.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert sorted(int(path.name) for path in started.iterdir()) == sorted(pids)  # both are in their 60 s task
    finally:
        parent.kill()
        parent.wait()
        parent.stdout.close()
    deadline = time.monotonic() + 30.0  # they go within a second; the bound only stops a test that would hang
    while not all(process_exited(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert all(process_exited(pid) for pid in pids)


def test_make_backend():
    with make_backend("serial", 1) as serial:
        assert isinstance(serial, SerialBackend) and serial.workers == 1
    with make_backend("process", 3, task_timeout_s=5.0) as pool:
        assert isinstance(pool, ProcessPoolBackend) and pool.workers == 3 and pool.task_timeout_s == 5.0
    with pytest.raises(ValueError, match="'serial' or 'process'"):
        make_backend("threads", 2)
    with pytest.raises(ValueError, match="at least 1"):
        make_backend("process", 0)


def test_worker_context_closes_the_old_env_when_the_config_changes(small_config):
    other = small_config.with_overrides({"env": {"ego_start_max_m": 450.0}})
    context = WorkerContext()
    try:
        first = context.env(small_config)
        assert context.env(small_config) is first
        first.reset(seed=0)
        second = context.env(other)
        assert second is not first
        second.reset(seed=0)  # libsumo allows one simulation per process: this fails unless `first` was closed
    finally:
        context.close()


def test_episodes_are_identical_with_every_backend(small_config):
    tasks = [Episode(small_config, seed) for seed in range(4)]
    with SerialBackend() as serial:
        reference = serial.run(tasks)
    with ProcessPoolBackend(1) as one, ProcessPoolBackend(2) as two:
        assert one.run(tasks) == reference
        assert two.run(tasks) == reference
    assert all(steps > 1 for _, steps in reference)
    assert len(set(reference)) > 1, "different seeds should give different episodes"
