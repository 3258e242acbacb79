"""Ray backend: same results as the other backends, recovery from killed actors and removed nodes, task errors,
timeouts, a missing Ray, the CLI's --backend/--address and bit-identical RAIL training.

One two-node Ray cluster (one CPU each) is shared by the module; each backend connects to it and disconnects on
close. Tasks are sumo_rail's own classes: Ray workers import them from the installed package.
"""


from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from typing import Any

import numpy as np
import pytest
from rail_runs import run_settings
from test_backends import process_exited
from test_cli import SMALL, invoke

from sumo_rail.config import Config
from sumo_rail.drivers.policies import load_policy
from sumo_rail.learning.rail.trainer import train
from sumo_rail.runners.backends import BackendError, ProcessPoolBackend, SerialBackend, TaskError
from sumo_rail.runners.factory import make_backend
from sumo_rail.runners.rollout import EpisodeResult, EpisodeTask, ExpertDriver, KeepDriver, RandomDriver

ray = pytest.importorskip("ray")
from ray.cluster_utils import Cluster  # noqa: E402

from sumo_rail.runners.ray_backend import INSTALL_HINT, RayBackend  # noqa: E402


@pytest.fixture(scope="module", autouse=True)
def no_usage_stats():
    """Ray must not try to report usage statistics from the tests."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("RAY_USAGE_STATS_ENABLED", "0")
        yield


@pytest.fixture(scope="module")
def cluster(no_usage_stats):
    """A head node and one more node, one CPU each."""
    node_args = {"num_cpus": 1, "object_store_memory": 100 * 1024**2}
    cluster = Cluster(initialize_head=True, head_node_args={**node_args, "include_dashboard": False})
    cluster.add_node(**node_args)
    cluster.wait_for_nodes()
    yield cluster
    if ray.is_initialized():  # a failed test's backend must not keep the driver connected to a removed node
        ray.shutdown()
    cluster.shutdown()


@pytest.fixture(scope="module")
def tasks(small_config_module: Config) -> list[EpisodeTask]:
    """Short recorded episodes of four drivers."""
    drivers = [ExpertDriver("normal"), RandomDriver(), KeepDriver(), ExpertDriver("sporty")]
    return [EpisodeTask(small_config_module, drivers[seed % 4], seed, record=True) for seed in range(8)]


@pytest.fixture(scope="module")
def reference(tasks: list[EpisodeTask]) -> list[EpisodeResult]:
    with SerialBackend() as serial:
        return serial.run(tasks)


def assert_same(results: list[EpisodeResult], expected: list[EpisodeResult]) -> None:
    """Equal metrics and bit-identical recorded steps, in task order."""
    assert len(results) == len(expected)
    for result, other in zip(results, expected, strict=True):
        assert result.metrics == other.metrics
        assert result.steps.keys() == other.steps.keys()
        assert all(np.array_equal(result.steps[name], other.steps[name]) for name in result.steps)


def run_with_fault(backend: RayBackend, tasks: list[EpisodeTask], fault: Any) -> tuple[list[Any], list[int]]:
    """Run `tasks`, calling `fault()` when the first result arrives; returns the results and arrival order."""
    arrivals: list[int] = []

    def on_result(index: int, result: Any) -> None:
        if not arrivals:
            fault()
        arrivals.append(index)

    return backend.run(tasks, on_result), arrivals


def wait_until_exited(pids: list[int], timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not all(process_exited(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    return all(process_exited(pid) for pid in pids)


def test_results_match_the_serial_and_process_backends_and_close_leaves_no_actor(cluster, tasks, reference):
    arrivals: list[int] = []
    with ProcessPoolBackend(2) as pool:
        assert_same(pool.run(tasks), reference)
    backend = RayBackend(2, address=cluster.address)
    try:
        assert backend.pids == []
        assert_same(backend.run(tasks, lambda index, result: arrivals.append(index)), reference)
        assert sorted(arrivals) == list(range(len(tasks)))
        # The head node's actor starts on a prestarted worker; the other node's may start only after these short
        # tasks are done, so more runs give it time (a slow machine needs them).
        deadline = time.monotonic() + 60.0
        while len(backend.pids) < 2 and time.monotonic() < deadline:
            assert_same(backend.run(tasks[:3]), reference[:3])
        pids = backend.pids
        assert len(pids) == 2 and os.getpid() not in pids
        assert_same(backend.run(tasks[:3]), reference[:3])
        assert backend.pids == pids, "actors live across runs"
    finally:
        backend.close()
    backend.close()
    assert not ray.is_initialized(), "the backend disconnects from the cluster it joined"
    assert wait_until_exited(pids), "closing kills the actors, and with them their SUMOs"
    with pytest.raises(BackendError, match="closed"):
        backend.run(tasks[:1])


def test_a_killed_actor_is_replaced_and_only_its_task_rerun(cluster, tasks, reference, caplog):
    with RayBackend(2, address=cluster.address) as backend:
        backend.run(tasks[:2])
        victim = backend.pids[0]
        results, arrivals = run_with_fault(backend, tasks, lambda: os.kill(victim, signal.SIGKILL))
        assert_same(results, reference)
        assert sorted(arrivals) == list(range(len(tasks))), "every result arrives exactly once"
        assert victim not in backend.pids
    assert f"Ray worker {victim} was lost (ActorDiedError" in caplog.text
    assert wait_until_exited([victim])


def test_a_removed_node_loses_only_its_tasks(cluster, tasks, reference, caplog):
    extra = cluster.list_all_nodes()[1]
    try:
        with RayBackend(2, address=cluster.address) as backend:
            backend.run(tasks[:2])
            results, arrivals = run_with_fault(backend, tasks, lambda: cluster.remove_node(extra))
            assert_same(results, reference)
            assert sorted(arrivals) == list(range(len(tasks)))
            assert len(backend.pids) == 1, "the replacement waits for a free CPU; the other actor did the work"
    finally:
        cluster.add_node(num_cpus=1, object_store_memory=100 * 1024**2)
        cluster.wait_for_nodes()
    assert "was lost (ActorDiedError" in caplog.text


def test_a_task_exception_is_a_task_error_and_not_retried(cluster, small_config_module, tasks, reference, caplog):
    failing = EpisodeTask(small_config_module, ExpertDriver("reckless"), 0)
    with RayBackend(2, address=cluster.address) as backend:
        with pytest.raises(TaskError, match=r"task 1 raised ValueError: unknown expert style 'reckless'"):
            backend.run([tasks[0], failing])
        assert "retrying" not in caplog.text
        assert_same(backend.run(tasks[:2]), reference[:2])


def test_a_task_that_always_times_out_fails_after_max_attempts_and_the_backend_stays_usable(cluster, tasks,
                                                                                             reference, caplog):
    with RayBackend(1, address=cluster.address, task_timeout_s=0.001, max_attempts=2) as backend:
        with pytest.raises(BackendError, match=r"task 0 got no result in 2 attempts \(last: timed out after 0.001 s\)"):
            backend.run(tasks[:1])
        assert "task 0: timed out after 0.001 s; retrying it (attempt 2 of 2)" in caplog.text
        backend.task_timeout_s = None
        assert_same(backend.run(tasks[:1]), reference[:1])


def test_missing_ray_gives_the_install_hint(monkeypatch):
    assert INSTALL_HINT == "the ray backend needs Ray: pip install 'sumo-rail[ray]'"
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(BackendError) as info:
        RayBackend(2)
    assert str(info.value) == INSTALL_HINT
    with pytest.raises(BackendError, match="pip install"):
        make_backend("ray", 2)
    result = invoke("evaluate", *SMALL, "--backend", "ray", "--episodes", "1")
    assert result.exit_code == 1 and INSTALL_HINT in result.output and "Traceback" not in result.output


def test_make_backend_makes_a_ray_backend_without_starting_ray():
    with make_backend("ray", 3, task_timeout_s=5.0, address="auto") as backend:
        assert isinstance(backend, RayBackend)
        assert (backend.workers, backend.task_timeout_s, backend.address) == (3, 5.0, "auto")
    assert not ray.is_initialized()
    with pytest.raises(ValueError, match="only used by the ray backend"):
        make_backend("process", 2, address="auto")


def test_cli_evaluate_on_a_local_ray_prints_the_same_table(no_usage_stats):
    """In a subprocess: a local Ray switches its process to token authentication for good, which would break the
    later connections of this process to the test cluster."""
    args = ["evaluate", *SMALL, "--policy", "expert", "--policy", "random", "--episodes", "2", "--workers", "2"]
    process = invoke(*args, "--backend", "process")
    assert process.exit_code == 0, process.output
    local_ray = subprocess.run([sys.executable, "-m", "sumo_rail_cli", *args, "--backend", "ray"],
                               capture_output=True, text=True, timeout=120)
    assert local_ray.returncode == 0, local_ray.stderr
    assert local_ray.stdout == process.stdout and "expert-normal" in process.stdout


@pytest.mark.parametrize("command", [["evaluate"], ["record-expert", "--out", "x.parquet"],
                                     ["train", "--demos", "x.parquet", "--out", "run"]])
def test_address_without_the_ray_backend_is_a_usage_error(command, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke(*command, "--address", "auto")
    assert result.exit_code == 2 and "--address needs --backend ray" in result.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("respawning", [False, True], ids=["paper", "respawning"])
def test_rail_training_gives_the_same_weights_as_the_process_pool(cluster, tmp_path, demos_path,
                                                                  small_config_module, respawning):
    settings = run_settings(demos_path, respawning=respawning)
    with ProcessPoolBackend(2) as pool:
        train(tmp_path / "process", settings, small_config_module, 2, pool, resume=False)
    with RayBackend(2, address=cluster.address) as backend:
        train(tmp_path / "ray", settings, small_config_module, 2, backend, resume=False)
    for name in ("policy_latest.npz", "policy_best.npz"):
        expected, _ = load_policy(tmp_path / "process" / name)
        actual, _ = load_policy(tmp_path / "ray" / name)
        assert np.array_equal(actual.parameters, expected.parameters)
        assert np.array_equal(actual.observation_mean, expected.observation_mean)
        assert np.array_equal(actual.observation_std, expected.observation_std)



def test_an_unreachable_address_fails_fast_with_one_sentence(no_usage_stats):
    """In a subprocess, so that this process's connection to the test cluster is not reused."""
    with socket.socket() as probe:  # a port that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    result = subprocess.run([sys.executable, "-m", "sumo_rail_cli", "evaluate", *SMALL, "--episodes", "1",
                             "--backend", "ray", "--address", f"127.0.0.1:{port}"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert f"nothing accepts connections at 127.0.0.1:{port}" in result.stderr
