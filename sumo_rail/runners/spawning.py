"""Starting a worker process that a Ctrl-C or a SIGTERM meant for its parent cannot kill while it starts.

Ctrl-C reaches the whole foreground process group, and so does the SIGTERM of a plain `timeout` (GNU timeout signals
its command's whole process group) or of a scheduler that stops a job's group. A spawned worker ignores both as soon
as its code runs (`ignore_stop_signals`: its parent decides how a command stops, and closes it), but before that it
is a Python still importing, which dies of a SIGINT with a KeyboardInterrupt traceback on the terminal, or silently of
a SIGTERM; the run then finds a worker lost ("environment process 0 was killed by signal 15"). `start_shielded`
starts the process with SIGINT and SIGTERM blocked, which the spawned child inherits (the signal mask survives fork
and exec), as CPython's own resource tracker is started: the worker never sees them, while its parent gets them as
before. A worker whose parent is gone exits by itself (its pipe closes), so ignoring them never orphans it."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
from multiprocessing import resource_tracker
from multiprocessing.process import BaseProcess

_PR_SET_PDEATHSIG = 1
"""prctl(2)'s option: the signal the kernel sends this process when the thread that started it ends."""

STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}
"""What stops a command: Ctrl-C and SIGTERM (the parent handles them; its workers ignore them)."""


def start_shielded(process: BaseProcess) -> None:
    """`process.start()` with SIGINT and SIGTERM blocked in this thread meanwhile (restored at once: one that arrives
    meanwhile is delivered to this process then), so that the child starts with them blocked."""
    resource_tracker.ensure_running()  # started by the first spawn otherwise, it would unblock SIGINT after itself
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        process.start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def ignore_stop_signals() -> None:
    """In a worker process (first thing): ignore SIGINT and SIGTERM, then unblock them (those that came while it
    started, blocked by `start_shielded`, are dropped): the parent stops the command and closes its workers."""
    for number in STOP_SIGNALS:
        signal.signal(number, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)


def die_with_parent() -> None:
    """In a worker process (first thing): on Linux, have the kernel kill it when its parent ends, however the parent
    ends and whatever the worker is doing (a long call that never lets its own parent watch run); a parent already
    gone ends it now. Elsewhere nothing: the worker's pipe closing ends it."""
    if not sys.platform.startswith("linux"):
        return
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    parent = multiprocessing.parent_process()
    if parent is not None and os.getppid() != parent.pid:
        os._exit(1)  # the parent ended before prctl: this process is already an orphan
