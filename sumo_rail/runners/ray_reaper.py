"""Ending a private local Ray with the process that started it, however that process ends (SIGKILL included).

`ray.init` on this machine starts Ray's processes as children of the driver, and the kernel ends the first of them
(the GCS, the raylet) with it: Ray's own fate sharing. The raylet's children, the workers (each with its SUMO) and
Ray's agents, notice the raylet's end by themselves: the workers within seconds, the agents only after a minute (they
first try to report it to the GCS, which is gone, for 60 s). `RayBackend` runs this file as a script beside a private
local Ray it starts. It follows the run's processes: those that started with the run's mark in their environment
(`MARK`, set while Ray starts) and every process below one of them (Ray's agents are started with an environment of
their own); when the pipe on its standard input closes (the backend was closed, or the driver ended, however), it
kills those still alive and exits. A process is known by its pid and its start time, so a pid used again by another
process is left alone. It imports nothing but the standard library (a plain script starts in milliseconds) and
ignores Ctrl-C and SIGTERM (it runs in a session of its own; the driver's end is its one signal). Linux only: it
reads /proc.
"""

from __future__ import annotations

import os
import select
import signal
import sys

MARK = "SUMO_RAIL_RAY_RUN"
"""The environment variable marking the processes of a private local Ray; its value names the run."""
POLL_S = 0.5
"""How often the run's processes are looked for [s]."""

Process = tuple[int, int]
"""A process: its pid and its start time (clock ticks after boot)."""


def processes() -> dict[Process, Process | None]:
    """Every process but this one, with its parent (None when unreadable)."""
    found: dict[int, tuple[int, int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and int(entry) != os.getpid():
            try:
                with open(f"/proc/{entry}/stat", "rb") as file:
                    fields = file.read().rsplit(b")", 1)[1].split()
            except OSError:
                continue  # gone meanwhile
            found[int(entry)] = (int(fields[1]), int(fields[19]))  # ppid, start time
    return {(pid, start): (parent, found[parent][1]) if parent in found else None
            for pid, (parent, start) in found.items()}


def marked(pid: int, token: str) -> bool:
    """Whether process `pid` started with MARK=token in its environment (False when unreadable: another user's)."""
    try:
        with open(f"/proc/{pid}/environ", "rb") as file:
            return f"{MARK}={token}".encode() in file.read().split(b"\0")
    except OSError:
        return False


def follow(token: str, driver: int, known: dict[Process, bool]) -> None:
    """Add the processes not seen before to `known` (True: the run's), parents before children; the driver's children
    not the run's are looked at again (one seen between its fork and its exec still has the driver's environment)."""
    for process, parent in sorted(processes().items(), key=lambda item: item[0][1]):
        if process not in known or (not known[process] and parent is not None and parent[0] == driver):
            known[process] = bool(parent is not None and known.get(parent)) or marked(process[0], token)


def main(token: str) -> None:
    """Follow the run's processes until standard input closes, then kill those still alive."""
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, signal.SIG_IGN)
    known: dict[Process, bool] = {}
    driver, stdin = os.getppid(), sys.stdin.fileno()
    while True:
        follow(token, driver, known)
        if select.select([stdin], [], [], POLL_S)[0] and not os.read(stdin, 4096):
            break
    follow(token, driver, known)
    alive = processes()
    for process in [process for process, ours in known.items() if ours and process in alive]:
        try:
            os.kill(process[0], signal.SIGKILL)
        except OSError:
            continue  # gone meanwhile


if __name__ == "__main__":
    main(sys.argv[1])
