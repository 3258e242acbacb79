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
