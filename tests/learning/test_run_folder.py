"""The run folder every training command shares: stopping on SIGINT / SIGTERM after the current step (gail, ppo)
or after the save under way (train, dagger)."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from sumo_rail.datasets import written_atomically
from sumo_rail.learning.run_folder import load_checkpoint, save_tensors, signals_deferred, stop_requests

SECOND_SIGNAL_INSIDE_THE_FIRST = textwrap.dedent("""
    import signal, sys
    from sumo_rail.learning.run_folder import stop_requests

    with stop_requests() as stop:
        handler = signal.getsignal(signal.SIGINT)
        inside = []

        def at_every_line(frame, event, arg):  # another Ctrl-C at each line the first one's handler runs
            if event == "line" and not inside:
                inside.append(True)
                handler(signal.SIGINT, None)
                inside.pop()
            return at_every_line

        sys.settrace(at_every_line)
        handler(signal.SIGINT, None)
        sys.settrace(None)
    print("stopped" if stop.is_set() else "running")
""")


def test_a_second_ctrl_c_inside_the_first_ones_handler_does_not_deadlock():
    # in a child process: a deadlocked main thread there is a timeout here (SIGKILL: the handlers hold SIGTERM)
    result = subprocess.run([sys.executable, "-c", SECOND_SIGNAL_INSIDE_THE_FIRST], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0 and result.stdout.strip() == "stopped", result.stderr


def test_signals_set_the_flag_inside_and_the_handlers_come_back_after():
    before = signal.getsignal(signal.SIGTERM)
    with stop_requests() as stop:
        assert not stop.is_set()
        signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGINT)
        assert stop.is_set()
    assert signal.getsignal(signal.SIGTERM) is before


def test_ctrl_c_during_a_save_takes_effect_after_it():
    finished = []
    with pytest.raises(KeyboardInterrupt):
        with signals_deferred():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.1)
            finished.append("save")
    assert finished == ["save"]


def test_a_state_saved_by_two_processes_has_the_same_bytes(tmp_path):
    """The temporary name a file is written under holds the writer's pid; the file's bytes must not (a resumed run's
    checkpoint against an uninterrupted run's)."""
    import torch

    state = {"format": "test", "weights": torch.arange(6.0).reshape(2, 3)}
    for folder, pid in (("first", 100), ("second", 200)):
        (tmp_path / folder).mkdir()
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(os, "getpid", lambda pid=pid: pid)
            with written_atomically(tmp_path / folder / "checkpoint.pt") as temporary:
                save_tensors(state, temporary)
    first, second = (tmp_path / folder / "checkpoint.pt" for folder in ("first", "second"))
    assert first.read_bytes() == second.read_bytes()
    assert torch.equal(load_checkpoint(second, "test")["weights"], state["weights"])

