"""Choosing a rollout backend by name: the one place that knows every backend (Ray itself stays lazy)."""

from __future__ import annotations

from sumo_rail.runners.backends import ProcessPoolBackend, RolloutBackend, SerialBackend
from sumo_rail.runners.ray_backend import RayBackend


def make_backend(name: str, workers: int, task_timeout_s: float | None = None,
                 address: str | None = None) -> RolloutBackend:
    """'serial', 'process' or 'ray' (ValueError with a one-sentence message otherwise); workers must be >= 1.

    The serial backend runs in the calling process, so it ignores `workers` and `task_timeout_s`. `address` is
    the Ray cluster of the ray backend (None: a local Ray); Ray is imported only for it."""
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    if address is not None and name != "ray":
        raise ValueError(f"address is only used by the ray backend, not {name!r}")
    if name == "serial":
        return SerialBackend()
    if name == "process":
        return ProcessPoolBackend(workers, task_timeout_s)
    if name == "ray":
        return RayBackend(workers, address, task_timeout_s)
    raise ValueError(f"backend must be 'ray', 'serial' or 'process', got {name!r}")
