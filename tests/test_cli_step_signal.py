"""`sumo-rail step-signal` as a user runs it: a report with its settings and provenance, reproducible, and one
sentence for bad input."""

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy

SMALL = ["--set", "scenario.length_m=900", "--set", "scenario.warmup_s=120", "--set", "scenario.snapshots=3",
         "--set", "scenario.snapshot_interval_s=10", "--set", "env.ego_start_max_m=400"]


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args))


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("demos") / "demos.parquet"
    assert invoke("record-expert", *SMALL, "--episodes", "2", "--out", str(path)).exit_code == 0
    return path


@pytest.fixture(scope="module")
def policy(tmp_path_factory) -> Path:
    shape = PolicyShape("linear", 56)
    path = tmp_path_factory.mktemp("policy") / "policy.npz"
    save_policy(Policy(shape, np.random.default_rng(0).normal(0, 0.5, shape.parameter_count)), path, {})
    return path


def test_the_report_holds_every_measure_with_its_settings_and_is_reproducible(tmp_path, demos, policy):
    args = ["step-signal", *SMALL, "--demos", str(demos), "--policy", str(policy), "--set", "rail.directions=3",
            "--warmup-rounds", "0", "--discriminator", "given", "--discriminator", "contrast", "--set",
            "rail.flip_rate=0.1", "--set", "discriminator.hidden=6", "--seed", "5"]
    first = invoke(*args, "--out", str(tmp_path / "a.json"))
    assert first.exit_code == 0, first.output
    second = invoke(*args, "--workers", "2", "--out", str(tmp_path / "b.json"))
    assert second.exit_code == 0, second.output
    report = json.loads((tmp_path / "a.json").read_text())
    assert set(report["rewards"]) == {"given", "contrast"} and "agreement" in report
    assert report["settings"]["rail"]["flip_rate"] == 0.1 and report["kind"] == "step_signal"
    assert report["settings"]["discriminator"]["hidden"] == 6  # the [discriminator] settings, seeded by --seed
    assert report["settings"]["rail"]["seed"] == report["settings"]["discriminator"]["seed"] == report["seed"] == 5
    assert report["versions"]["sumo"] and report["config"]["scenario"]["length_m"] == 900
    assert 0 < report["flip_rate"] <= 0.2 and report["nu"] != 0.03  # nu was set by the flip rate
    assert len(report["returns"]["agreement"]["plus"]) == 2 and len(report["returns"]["agreement"]["plus"][0]) == 3
    for key in ("nu", "flip_rate", "rewards", "agreement", "returns"):
        assert report[key] == json.loads((tmp_path / "b.json").read_text())[key]  # any worker count
    assert "| discriminator: contrast |" in first.output


def test_bad_input_is_one_sentence(tmp_path, demos, policy):
    missing = invoke("step-signal", *SMALL, "--demos", str(demos), "--policy", str(tmp_path / "none.npz"))
    assert missing.exit_code == 1 and "does not exist" in missing.output and "Traceback" not in missing.output
    lane_block = invoke("step-signal", *SMALL, "--set", "observation.lane_block=1", "--demos", str(demos),
                        "--policy", str(policy))
    assert lane_block.exit_code != 0 and "Traceback" not in lane_block.output
    other = tmp_path / "acceleration.npz"  # a policy of the acceleration interface (111 actions), paper demonstrations
    shape = PolicyShape("linear", 56, actions=111)
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), other, {})
    mismatch = invoke("step-signal", *SMALL, "--demos", str(demos), "--policy", str(other))
    assert mismatch.exit_code == 2 and "chooses among 111 actions" in mismatch.output, mismatch.output
    other_demos = invoke("step-signal", *SMALL, "--set", "actions.interface=acceleration", "--demos", str(demos),
                         "--policy", str(other))  # the paper's demonstrations, a run of the acceleration interface
    assert other_demos.exit_code == 2 and "holds demonstrations of the paper interface" in other_demos.output
    for word in ("rail.top=40", "rail.directions=2"):
        refused = invoke("step-signal", *SMALL, "--demos", str(demos), "--policy", str(policy), "--set", word)
        assert refused.exit_code == 2 and word.split("=")[0] in refused.output
