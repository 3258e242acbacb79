"""Starting a worker process that a Ctrl-C meant for its parent cannot kill while it starts.

Ctrl-C reaches the whole foreground process group. A spawned worker ignores SIGINT as soon as its code runs (its
parent decides how a command stops), but before that it is a Python still importing, which dies of it with a
KeyboardInterrupt traceback on the terminal; the run then finds a worker lost. `start_shielded` starts the process
with SIGINT blocked, which the spawned child inherits (the signal mask survives fork and exec), as CPython's own
resource tracker is started: the worker never sees a Ctrl-C, while its parent gets it as before."""

from __future__ import annotations

import signal
from multiprocessing import resource_tracker
from multiprocessing.process import BaseProcess


def start_shielded(process: BaseProcess) -> None:
    """`process.start()` with SIGINT blocked in this thread meanwhile (restored at once: a Ctrl-C that arrives
    meanwhile is delivered to this process then), so that the child starts with SIGINT blocked."""
    resource_tracker.ensure_running()  # started by the first spawn otherwise, it would unblock SIGINT after itself
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        process.start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
