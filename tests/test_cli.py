import contextlib
import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import click
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli
from sumo_rail_cli.settings import resolve_settings

import sumo_rail
from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.evaluation.fidelity import ACTION_NAMES
from sumo_rail.evaluation.statistics import MIN_PAIRS
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.observation import observation_names


def small_road(length_m: float, ego_start_max_m: float) -> tuple[list[str], Config]:
    """A short road (a 120 s warm-up, 3 warm states 10 s apart, egos starting within `ego_start_max_m`): its --set
    words for the commands and its Config, made from one dict."""
    settings = {"scenario": {"length_m": length_m, "warmup_s": 120.0, "snapshots": 3, "snapshot_interval_s": 10.0},
                "env": {"ego_start_max_m": ego_start_max_m}}
    words = [word for section, values in settings.items() for key, value in values.items()
             for word in ("--set", f"{section}.{key}={value:g}")]
    return words, Config.from_dict(settings)


SMALL, SMALL_CONFIG = small_road(1500.0, 500.0)


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


def hand_made_policy(path: Path, action: int, observation_size: int = 56) -> Path:
    """A linear policy whose only non-zero parameter is the bias of `action`."""
    shape = PolicyShape("linear", observation_size)
    parameters = np.zeros(shape.parameter_count, dtype=np.float32)
    parameters[5 * observation_size + action] = 1.0
    save_policy(Policy(shape, parameters), path, {"observation_names": observation_names(SMALL_CONFIG)})
    return path


def test_version_and_help():
    assert sumo_rail.__version__ in invoke("--version").output
    result = invoke("--help")
    assert result.exit_code == 0 and "record-expert" in result.output and "evaluate" in result.output


def test_learner_commands_help_shows_at_most_20_options_and_no_learner_setting():
    """The learners' settings are --set words, not options: --help stays short, and one name per idea holds (the
    network's shape is network.shape, not --policy; parallel SUMOs are --workers or a learner's envs)."""
    for command in ("train", "step-signal", "dagger", "gail", "ppo", "evaluate", "record-expert", "evaluate-scene"):
        result, shown = invoke(command, "--help"), cli.commands[command]
        options = [param for param in shown.get_params(shown.make_context(command, ["--help"], resilient_parsing=True))
                   if isinstance(param, click.Option) and not param.hidden]
        assert result.exit_code == 0 and len(options) <= 20, (command, len(options))
        names = {name for option in options for name in option.opts}
        assert "--help-settings" in names and "--envs" not in names, command
        assert not names & {"--directions", "--bc-epochs", "--disc-hidden", "--hidden", "--n-steps", "--style"}
        assert ("--policy" in names) == (command in ("evaluate", "evaluate-scene", "step-signal")), command


def test_record_expert_is_identical_for_any_worker_count_and_run(tmp_path):
    paths = []
    for name, workers in (("a", "1"), ("b", "2"), ("c", "2")):
        paths.append(tmp_path / f"{name}.parquet")
        result = invoke("record-expert", *SMALL, "--episodes", "3", "--seed", "5", "--expert", "calm",
                        "--workers", workers, "--out", str(paths[-1]))
        assert result.exit_code == 0, result.output
    contents = [path.read_bytes() for path in paths]
    assert contents[0] == contents[1] == contents[2]
    demos = read_demonstrations(paths[0], observation_size=56)
    assert sorted(set(demos.episodes.tolist())) == [0, 1, 2]
    metadata = read_metadata(paths[0])
    assert metadata["style"] == "calm" and metadata["seed"] == 5 and metadata["config"] == SMALL_CONFIG.to_dict()
    assert metadata["episode_seeds"] == [15, 18, 21]
    table = pq.read_table(paths[0])
    assert table.num_rows == len(demos.actions) and set(table.column("episode_seed").to_pylist()) == {15, 18, 21}


def test_record_expert_with_two_egos_a_simulation_is_identical_for_any_worker_count(tmp_path):
    paths = []
    for name, workers in (("a", "1"), ("b", "2")):
        paths.append(tmp_path / f"{name}.parquet")
        result = invoke("record-expert", *SMALL, "--episodes", "3", "--seed", "5", "--egos", "2", "--workers",
                        workers, "--out", str(paths[-1]))
        assert result.exit_code == 0, result.output
        assert "wrote" in result.output and "3 episodes" in result.output
    assert paths[0].read_bytes() == paths[1].read_bytes()
    metadata = read_metadata(paths[0])
    assert metadata["egos"] == 2 and metadata["episode_seeds"] == [15, 18, 21] and metadata["episodes"] == 3
    assert metadata["simulation_seeds"] == [15, 21] and metadata["requested_episodes"] == 3
    table = pq.read_table(paths[0]).to_pandas()
    assert sorted(table["episode_seed"].unique()) == [15, 18, 21] and table["episode"].max() == 2
    alone = tmp_path / "alone.parquet"
    assert invoke("record-expert", *SMALL, "--episodes", "3", "--seed", "5", "--out", str(alone)).exit_code == 0
    columns = ["action", "position_m", "speed_mps"]
    first_alone = pq.read_table(alone).to_pandas().query("episode == 0")[columns].reset_index(drop=True)
    first_shared = table.query("episode == 0")[columns].reset_index(drop=True)
    assert not first_alone.equals(first_shared)  # the same seed, with another ego on the road


@pytest.mark.parametrize(("command", "egos"), [
    (["record-expert"], "--egos"), (["dagger", "--demos", "d.parquet"], "dagger.egos"),
    (["train", "--demos", "d.parquet"], "rail.egos"), (["ppo"], "ppo.egos"), (["gail", "--demos", "d.parquet"],
    "gail.egos"),
    (["step-signal", "--demos", "d.parquet", "--policy", "p.npz"], "rail.egos")])
def test_more_egos_than_the_road_holds_is_a_usage_error_before_any_work(tmp_path, command, egos):
    words = ("--egos", "400") if egos == "--egos" else ("--set", f"{egos}=400")
    result = invoke(*command, *SMALL, *words, "--out", str(tmp_path / "out"))
    assert result.exit_code == 2 and f"'{egos}'" in result.output and "use fewer egos" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "out").exists()


def test_record_expert_refuses_to_overwrite_and_bad_counts(tmp_path):
    out = tmp_path / "demos.parquet"
    out.write_text("precious")
    result = invoke("record-expert", *SMALL, "--episodes", "1", "--out", str(out))
    assert result.exit_code == 2 and "--overwrite" in result.output and out.read_text() == "precious"
    result = invoke("record-expert", *SMALL, "--episodes", "0", "--out", str(tmp_path / "x.parquet"))
    assert result.exit_code == 2 and "--episodes" in result.output
    result = invoke("record-expert", *SMALL, "--episodes", "1", "--out", str(tmp_path / "no" / "x.parquet"))
    assert result.exit_code == 2 and "does not exist" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demos.parquet"]


def test_evaluate_puts_drivers_side_by_side_and_is_reproducible(tmp_path):
    policy = hand_made_policy(tmp_path / "always_right.npz", action=4)
    outs = [tmp_path / "m1.parquet", tmp_path / "m2.parquet"]
    outputs = []
    for out, workers in zip(outs, ("1", "2"), strict=True):
        result = invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--policy", str(policy),
                        "--episodes", "2", "--seed", "1000", "--workers", workers, "--out", str(out))
        assert result.exit_code == 0, result.output
        outputs.append(result.stdout)
    summaries = [output.rsplit("wrote", 1)[0] for output in outputs]
    assert summaries[0] == summaries[1]
    assert "expert-normal" in outputs[0] and "always_right" in outputs[0]
    for row in ("agreement ", "lane_change_recall", "lane_change_precision", "average_speed_kmh", "overtakes"):
        assert row in outputs[0]
    assert "mean [95% interval]" in outputs[0] and "difference to expert-normal on the same seeds" in outputs[0]
    assert "1.000 [1.000, 1.000]" in outputs[0]  # the expert agrees with itself
    assert "distance of each driver's distributions to expert-normal's" in outputs[0]
    frames = [pd.read_parquet(out) for out in outs]
    pd.testing.assert_frame_equal(frames[0], frames[1])
    frame = frames[0]
    assert frame["policy"].tolist() == ["expert-normal"] * 2 + ["keep"] * 2 + ["always_right"] * 2
    assert frame["seed"].tolist() == [3001, 3004] * 3
    always_right = frame[frame["policy"] == "always_right"]
    assert (always_right["action_lane_right"] == always_right["steps"]).all()
    assert (frame[frame["policy"] == "keep"]["lane_changes"] == 0).all()
    assert read_metadata(outs[0])["kind"] == "episode_metrics"
    assert (frame[frame["policy"] == "expert-normal"]["agreement"] == 1.0).all()
    assert (always_right[[f"confusion_lane_right_{name}" for name in ACTION_NAMES]].sum(axis=1)
            == always_right["steps"]).all()
    decisions = pd.read_parquet(tmp_path / "m1.decisions.parquet")
    assert len(decisions) == frame["steps"].sum() and read_metadata(tmp_path / "m1.decisions.parquet")["kind"] == (
        "decisions")
    assert (decisions[decisions["policy"] == "always_right"]["action"] == 4).all()


def test_evaluate_reference_must_be_a_driver(tmp_path):
    result = invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--reference", "random",
                    "--episodes", "1")
    assert result.exit_code == 2 and "'random' is not one of the drivers (expert-normal, keep)" in result.output


def test_evaluate_against_another_reference_marks_detectable_differences(tmp_path):
    result = invoke("evaluate", *SMALL, "--policy", "expert", "--policy", "keep", "--reference", "keep",
                    "--episodes", str(MIN_PAIRS))
    assert result.exit_code == 0, result.output
    differences = result.output.split("difference to keep on the same seeds")[1]
    agreement = next(line for line in differences.splitlines() if line.startswith("agreement "))
    assert agreement.split()[1].startswith("+") and agreement.rstrip().endswith("*")


def test_policies_of_run_folders_are_named_by_run(tmp_path):
    for run in ("run_a", "run_b"):
        (tmp_path / run).mkdir()
        (tmp_path / run / "run.json").write_text("{}")
        hand_made_policy(tmp_path / run / "policy_bc.npz", action=0)
    result = invoke("evaluate", *SMALL, "--policy", str(tmp_path / "run_a" / "policy_bc.npz"), "--policy",
                    str(tmp_path / "run_b" / "policy_bc.npz"), "--episodes", "1")
    assert result.exit_code == 0, result.output
    assert "run_a/policy_bc" in result.output and "run_b/policy_bc" in result.output


@pytest.mark.parametrize("word", ["bogus", "sampled:bogus"])
def test_a_policy_word_that_is_no_driver_and_no_file_is_a_usage_error_listing_the_words(tmp_path, word):
    """Was exit 1 "policy file bogus does not exist", as if the word had to be a file."""
    out = tmp_path / "m.parquet"
    result = invoke("evaluate", *SMALL, "--policy", word, "--out", str(out))
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 2 and len(errors) == 1 and "Traceback" not in result.output, result.output
    assert f"'{word}' is neither a driver word" in errors[0] and "keep, random" in errors[0] and not out.exists()


def test_evaluate_rejects_bad_policies_without_writing(tmp_path):
    out = tmp_path / "m.parquet"
    wrong_size = hand_made_policy(tmp_path / "wrong.npz", action=0, observation_size=60)
    result = invoke("evaluate", *SMALL, "--policy", str(wrong_size), "--out", str(out))
    assert result.exit_code == 1 and "reads 60 observation values" in result.output
    corrupt = tmp_path / "corrupt.npz"
    corrupt.write_bytes(b"garbage")
    result = invoke("evaluate", *SMALL, "--policy", str(corrupt), "--out", str(out))
    assert result.exit_code == 1 and "corrupt.npz" in result.output
    result = invoke("evaluate", *SMALL, "--policy", str(tmp_path / "missing.npz"))  # no file there: a bad word
    assert result.exit_code == 2 and "nor an existing policy file" in result.output
    result = invoke("evaluate", *SMALL, "--policy", "expert:reckless")
    assert result.exit_code == 2 and "reckless" in result.output
    result = invoke("evaluate", *SMALL, "--policy", "expert:")  # a style left out is no style
    assert result.exit_code == 2 and "unknown expert style ''" in result.output
    assert "Traceback" not in result.output and not out.exists()


@pytest.mark.parametrize(("args", "fragment"), [
    (["--set", "scenario.lanes=0"], "scenario.lanes"),
    (["--set", "scenario.colour=1"], "scenario.colour"),
    (["--set", "lanes=3"], "SECTION.KEY=VALUE"),
    (["--set", "lidar.range_m=-1"], "lidar.range_m"),
    (["--set", "lidar.beams=7"], "360"),
    (["--set", "scenario.flow_veh_per_h=-100"], "flow_veh_per_h"),
    (["--config", "does-not-exist.toml"], "does-not-exist.toml"),
    (["--episodes", "0"], "--episodes"),
    (["--workers", "0"], "--workers"),
])
def test_bad_input_is_a_one_line_usage_error(args, fragment):
    result = invoke("evaluate", *args)
    assert result.exit_code == 2
    assert fragment in result.output
    assert "Traceback" not in result.output
    assert isinstance(result.exception, SystemExit)


def test_unknown_key_in_config_file(tmp_path: Path):
    path = tmp_path / "bad.toml"
    path.write_text("[env]\ndecision_period = 1.0\n")
    result = invoke("evaluate", "--config", str(path))
    assert result.exit_code == 2 and "env.decision_period" in result.output


def test_the_recommended_preset_is_the_lane_and_route_blocks_in_every_output(tmp_path):
    outs = {}
    for name, args in (("preset", ["--preset", "recommended"]),
                       ("set", ["--set", "observation.lane_block=1", "--set", "observation.route_block=1"])):
        outs[name] = tmp_path / f"{name}.parquet"
        result = invoke("record-expert", *SMALL, *args, "--episodes", "1", "--out", str(outs[name]))
        assert result.exit_code == 0, result.output
    assert read_metadata(outs["preset"])["config"] == read_metadata(outs["set"])["config"]
    assert read_metadata(outs["preset"])["config"]["observation"]["lane_block"] == 1
    assert pq.read_table(outs["preset"]).equals(pq.read_table(outs["set"]))


def test_the_config_file_changes_the_preset_and_set_changes_both(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[observation]\nlane_block = 0\n[scenario]\nlanes = 4\n")
    assert resolve_settings("recommended", None, ())[0] == Config.preset("recommended")
    assert resolve_settings("recommended", path, ())[0] == Config().with_overrides({"scenario": {"lanes": 4},
                                                                                "observation": {"route_block": 1}})
    assert resolve_settings("recommended", path, ("scenario.lanes=3",))[0].scenario.lanes == 3
    assert invoke("evaluate", "--preset", "best").exit_code == 2


def test_gui_without_a_display_is_a_one_sentence_error():
    env = {key: value for key, value in os.environ.items() if key not in ("DISPLAY", "WAYLAND_DISPLAY")}
    result = subprocess.run([sys.executable, "-m", "sumo_rail_cli", "evaluate", *SMALL, "--gui",
                             "--episodes", "1"], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 1, result.stderr
    assert "sumo-gui" in result.stderr and "Traceback" not in result.stderr


@contextlib.contextmanager
def command_process(*args: str, **popen: Any) -> Iterator[tuple[subprocess.Popen, queue.Queue]]:
    """`sumo-rail ARGS` in a child process, with its output lines (stdout and stderr together; progress goes to
    stderr as plain lines, it not being a terminal) on a queue as they come, None at the end. The child is killed
    on leaving, so that a failing test leaves no process behind."""
    process = subprocess.Popen([sys.executable, "-m", "sumo_rail_cli", *args], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, **popen)
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        for line in process.stdout:
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        yield process, lines
    finally:
        process.kill()
        process.wait()
        reader.join(timeout=10)
        process.stdout.close()


def read_until(lines: queue.Queue, pattern: str, timeout_s: float = 300.0) -> str:
    """The output up to and including the first line matching `pattern`; fails if the output ends first or no
    such line comes within `timeout_s` [s] (a bound on a hang, not on speed)."""
    seen: list[str] = []
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.0))
        except queue.Empty:
            pytest.fail(f"no line matching {pattern!r} within {timeout_s:.0f} s; output so far:\n{''.join(seen)}")
        if line is None:
            pytest.fail(f"the command ended without a line matching {pattern!r}; its output:\n{''.join(seen)}")
        seen.append(line)
        if re.search(pattern, line):
            return "".join(seen)


def rest_of(lines: queue.Queue, timeout_s: float = 60.0) -> str:
    """The output after what was read, up to its end (which must come within `timeout_s` [s])."""
    rest: list[str] = []
    try:
        rest.extend(iter(lambda: lines.get(timeout=timeout_s), None))
    except queue.Empty:
        pytest.fail(f"the output did not end within {timeout_s:.0f} s; its last lines:\n{''.join(rest[-20:])}")
    return "".join(rest)


def test_ctrl_c_leaves_no_partial_output(tmp_path):
    out = tmp_path / "demos.parquet"
    # far more episodes than the first progress line (after 10 s) can see done, even on a fast idle machine
    with command_process("record-expert", *SMALL, "--episodes", "20000", "--workers", "2", "--out", str(out)) as (
            process, lines):
        # a progress line: episodes are recorded, and a command writing as it goes would have begun its file
        output = read_until(lines, r"^recording: [1-9]\d*/20000 episodes")
        assert "20000/20000" not in output, "the recording ended before it could be interrupted"
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 1
        output += rest_of(lines)
    assert "interrupted; nothing was written to" in output and "Traceback" not in output, output
    assert list(tmp_path.iterdir()) == []  # neither the file nor a temporary


def test_train_bad_input(tmp_path):
    result = invoke("train", *SMALL, "--demos", str(tmp_path / "missing.parquet"), "--out", str(tmp_path / "run"))
    assert result.exit_code == 1 and "does not exist" in result.output
    result = invoke("train", *SMALL, "--demos", "x.parquet", "--set", "rail.directions=4", "--set", "rail.top=5",
                    "--out", "run")
    assert result.exit_code == 2 and "rail.top" in result.output
    result = invoke("train", *SMALL, "--demos", "x.parquet", "--set", "rail.rollout_decisions=100", "--set",
                    "rail.episodes_per_rollout=2", "--out", "run")
    assert result.exit_code == 2 and "rail.rollout_decisions" in result.output and "Traceback" not in result.output


def test_train_interrupted_keeps_a_checkpoint_and_resumes(tmp_path):
    demos = tmp_path / "demos.parquet"
    assert invoke("record-expert", *SMALL, "--episodes", "2", "--out", str(demos)).exit_code == 0
    run = tmp_path / "run"
    command = ["train", *SMALL, "--demos", str(demos), "--set", "rail.directions=2",
               "--set", "rail.top=1", "--iterations", "500", "--out", str(run)]
    # started with SIGINT ignored, as a shell script's background job is: Ctrl-C must still stop it
    with command_process(*command, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) as (process,
                                                                                                       lines):
        output = read_until(lines, r"^training: [1-9]\d*/500 iterations")  # at least one iteration is complete
        process.send_signal(signal.SIGINT)
        assert process.wait(timeout=60) == 1
        output += rest_of(lines)
    assert "--resume" in output and "Traceback" not in output, output
    done = len(pd.read_parquet(run / "log.parquet"))
    assert 1 <= done < 500
    assert not [p for p in run.iterdir() if p.name.endswith(".tmp")]
    assert "behaviour cloning: train accuracy" in output  # BC initialises RAIL by default
    result = invoke("train", *SMALL, "--demos", str(demos), "--set", "rail.directions=2", "--set", "rail.top=1",
                    "--iterations", str(done + 1), "--eval-episodes", "1", "--out", str(run), "--resume")
    assert result.exit_code == 0, result.output
    assert f"iteration {done + 1}: validation agreement" in result.output  # the last iteration is evaluated
    assert len(pd.read_parquet(run / "log.parquet")) == done + 1


def test_evaluate_on_the_validation_pool(tmp_path):
    outs = {pool: tmp_path / f"{pool}.parquet" for pool in ("test", "validation")}
    for pool, out in outs.items():
        result = invoke("evaluate", *SMALL, "--policy", "keep", "--episodes", "2", "--pool", pool, "--out", str(out))
        assert result.exit_code == 0, result.output
        assert read_metadata(out)["pool"] == pool
    test, validation = (pd.read_parquet(out) for out in outs.values())
    assert test["seed"].tolist() == validation["seed"].tolist()
    assert test["distance_m"].tolist() != validation["distance_m"].tolist()  # other warm traffic, same seeds
    assert invoke("evaluate", *SMALL, "--pool", "train").exit_code == 2  # training states are never evaluated on
