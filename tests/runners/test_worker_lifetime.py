"""Workers live no longer than their parent: ended by a SIGTERM whatever they are doing, none is left behind.

Task classes are top-level so that spawned workers can unpickle them."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from sumo_rail.runners.backends import WorkerContext


@dataclass(frozen=True)
class HoldsTheInterpreter:
    """Touches `started_dir / <pid>`, then computes for hours in one C call that never lets another thread run (so
    the worker's own watch of its parent cannot act)."""

    started_dir: Path

    def run(self, context: WorkerContext) -> int:
        (self.started_dir / str(os.getpid())).touch()
        return sum(range(10**15))


def exited(pid: int) -> bool:
    """The process is gone or a zombie (a container's init may be slow to reap orphans)."""
    try:
        return "\tZ" in Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the kernel's parent-death signal is Linux's")
def test_no_worker_outlives_a_sigterm_to_its_parent_whatever_it_is_doing(tmp_path):
    started = tmp_path / "started"
    started.mkdir()
    script = textwrap.dedent(f"""
        import sys
        from pathlib import Path
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        from test_worker_lifetime import HoldsTheInterpreter
        from sumo_rail.runners.backends import ProcessPoolBackend
        ProcessPoolBackend(3).run([HoldsTheInterpreter(Path({str(started)!r}))] * 3)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 120.0  # a bound on a hang, not on speed
        while len(list(started.iterdir())) < 3 and parent.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        pids = [int(path.name) for path in started.iterdir()]
        assert len(pids) == 3, "the three workers did not all start their task"
        parent.send_signal(signal.SIGTERM)
        assert parent.wait(timeout=60) == -signal.SIGTERM
    finally:
        parent.kill()
        parent.wait()
    deadline = time.monotonic() + 30.0  # they go at once; the bound only stops a test that would hang
    while not all(exited(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = [pid for pid in pids if not exited(pid)]
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert left == []


def descendants(pid: int) -> list[int]:
    """Every process below `pid` (Linux's /proc children lists)."""
    found, waiting = [], [pid]
    while waiting:
        for task in Path(f"/proc/{waiting.pop()}/task").glob("*"):
            try:
                children = [int(child) for child in (task / "children").read_text().split()]
            except FileNotFoundError:
                continue
            found += children
            waiting += children
    return found


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the kernel's parent-death signal is Linux's")
def test_no_process_of_a_local_ray_outlives_a_sigkill_to_its_driver(tmp_path):
    """--backend ray without --address starts a private Ray: all of it ends with its driver, even a driver SIGKILLed
    while its actor holds the interpreter: the actors (each with its SUMO), the raylet, the GCS, and Ray's agents,
    which by themselves linger a minute."""
    pytest.importorskip("ray")
    started = tmp_path / "started"
    started.mkdir()
    script = textwrap.dedent(f"""
        from pathlib import Path
        from test_worker_lifetime import HoldsTheInterpreter
        from sumo_rail.runners.ray_backend import RayBackend
        RayBackend(1).run([HoldsTheInterpreter(Path({str(started)!r}))])
    """)
    environment = {**os.environ, "PYTHONPATH": str(Path(__file__).parent), "RAY_USAGE_STATS_ENABLED": "0"}
    driver = subprocess.Popen([sys.executable, "-c", script], env=environment, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120.0  # a bound on a hang, not on speed
        while not any(started.iterdir()) and driver.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert any(started.iterdir()), "the actor did not start its task"
        ray_processes = descendants(driver.pid)
        assert {int(path.name) for path in started.iterdir()} <= set(ray_processes)
    finally:
        driver.kill()
        driver.wait()
    deadline = time.monotonic() + 20.0  # they go within a second or two
    while not all(exited(pid) for pid in ray_processes) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = {pid: Path(f"/proc/{pid}/cmdline").read_bytes()[:40] for pid in ray_processes if not exited(pid)}
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    assert left == {}
