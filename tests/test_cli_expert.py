"""Any driver as the expert (`--expert STYLE|POLICY_FILE`): recorded, asked for agreement and labelling, named in
the outputs' metadata, and checked against the configuration's observation layout."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from test_cli import invoke, small_road

from sumo_rail.config import Config
from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyFileError, PolicyShape, save_policy
from sumo_rail.runners.experts import expert_reference, resolve_expert
from sumo_rail.runners.tables import read_demonstrations
from sumo_rail.sim.observation import observation_names

SMALL, CONFIG = small_road(900.0, 400.0)


@pytest.fixture(scope="module")
def learned_expert(tmp_path_factory) -> Path:
    """A policy that changes its decisions with the traffic (random weights), saved with the layout it reads."""
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    path = tmp_path_factory.mktemp("expert") / "learned.npz"
    parameters = np.random.default_rng(3).normal(0, 1.0, shape.parameter_count)
    save_policy(Policy(shape, parameters), path, {"observation_names": observation_names(CONFIG)})
    return path


def test_a_policy_file_as_the_expert_agrees_with_itself_exactly(tmp_path, learned_expert):
    out = tmp_path / "metrics.parquet"
    result = invoke("evaluate", *SMALL, "--policy", str(learned_expert), "--policy", "expert:normal", "--expert",
                    str(learned_expert), "--episodes", "3", "--out", str(out))
    assert result.exit_code == 0, result.output
    metrics = pd.read_parquet(out)
    mine = metrics[metrics["policy"] == "learned"]
    assert (mine["agreement"] == 1.0).all() and (mine["reference"] == "expert-learned").all()
    rule_based = metrics[metrics["policy"] == "expert-normal"]
    assert (rule_based["agreement"] < 1.0).any()  # the rule-based driver is measured against the learned expert
    assert read_metadata(out)["expert"] == expert_reference(str(learned_expert))  # absolute path and hash


def test_a_distilled_expert_is_its_own_reference_not_the_expert_it_learned_from(tmp_path):
    """A policy file that records the expert it learned from (as every trained policy does), as --expert: the
    expert driver is compared with itself, a learner of it with it."""
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    distilled = tmp_path / "distilled.npz"
    parameters = np.random.default_rng(4).normal(0, 1.0, shape.parameter_count)
    metadata = {"observation_names": observation_names(CONFIG), "expert": "normal"}
    save_policy(Policy(shape, parameters), distilled, metadata)
    out = tmp_path / "metrics.parquet"
    result = invoke("evaluate", *SMALL, "--policy", "expert", "--expert", str(distilled), "--episodes", "2",
                    "--out", str(out))
    assert result.exit_code == 0, result.output
    metrics = pd.read_parquet(out)
    assert metrics["policy"].unique().tolist() == ["expert-distilled"]
    assert (metrics["agreement"] == 1.0).all() and (metrics["reference"] == "expert-distilled").all()


def test_recording_a_policy_file_keeps_its_decisions_and_names_it(tmp_path, learned_expert):
    out = tmp_path / "demos.parquet"
    result = invoke("record-expert", *SMALL, "--expert", str(learned_expert), "--episodes", "2", "--out", str(out))
    assert result.exit_code == 0, result.output
    demos = read_demonstrations(out, len(observation_names(CONFIG)))
    from sumo_rail.drivers.policies import load_policy

    policy, _ = load_policy(learned_expert)
    assert np.array_equal(np.argmax(policy.logits(demos.observations), axis=1), demos.actions)
    assert len(set(demos.actions.tolist())) > 1
    assert demos.metadata["expert"] == expert_reference(str(learned_expert)) and "style" not in demos.metadata
    # DAgger run on these demonstrations asks the same expert by default, and records it
    run = tmp_path / "dagger"
    result = invoke("dagger", *SMALL, "--demos", str(out), "--rounds", "1", "--set", "dagger.episodes_per_round=1",
                    "--set", "bc.epochs=2", "--eval-every", "1", "--eval-episodes", "1", "--out", str(run))
    assert result.exit_code == 0, result.output
    assert json.loads((run / "run.json").read_text())["expert"] == expert_reference(str(learned_expert))
    dataset = pq.read_table(run / "dataset.parquet")
    labelled = np.stack(dataset.column("observation").to_pylist())
    assert np.array_equal(np.argmax(policy.logits(labelled), axis=1), dataset.column("action").to_pylist())


def test_an_expert_of_another_observation_layout_is_one_sentence(tmp_path, learned_expert):
    result = invoke("evaluate", *SMALL, "--set", "observation.lane_block=1", "--expert", str(learned_expert),
                    "--episodes", "1")
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert str(learned_expert) in result.output and "observation" in result.output
    unknown = invoke("record-expert", *SMALL, "--expert", "speedy", "--episodes", "1", "--out",
                     str(tmp_path / "x.parquet"))
    assert unknown.exit_code == 2 and "calm" in unknown.output and not (tmp_path / "x.parquet").exists()
    for not_a_driver in ("", str(tmp_path)):  # nothing, a directory
        result = invoke("record-expert", *SMALL, "--expert", not_a_driver, "--episodes", "1", "--out",
                        str(tmp_path / "x.parquet"))
        assert result.exit_code == 2 and "not a style" in result.output


def test_a_layout_or_scale_mismatch_names_the_settings_the_policy_was_trained_with(tmp_path):
    path = tmp_path / "trained.npz"
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), path,
                {"observation_names": observation_names(CONFIG), "config": CONFIG.to_dict()})
    other = Config.from_dict({**CONFIG.to_dict(), "observation": {"lane_block": 1}, "lidar": {"beams": 12}})
    with pytest.raises(PolicyFileError, match=r"has 44; it was trained with --set lidar\.beams=24 --set observation\."
                       r"lane_block=0 and this configuration has lidar\.beams=12 observation\.lane_block=1$"):
        resolve_expert(str(path), other)
    fewer_lanes = Config.from_dict({**CONFIG.to_dict(), "scenario": {**CONFIG.to_dict()["scenario"], "lanes": 4}})
    with pytest.raises(PolicyFileError, match=r"--set scenario\.lanes=5 and this configuration has scenario\.lanes=4$"):
        resolve_expert(str(path), fewer_lanes)
    shorter_lidar = Config.from_dict({**CONFIG.to_dict(), "lidar": {"beams": 24, "range_m": 80.0}})
    with pytest.raises(PolicyFileError, match=r"reads observations scaled otherwise than this configuration's; it was "
                       r"trained with --set lidar\.range_m=100\.0 and this configuration has lidar\.range_m=80\.0$"):
        resolve_expert(str(path), shorter_lidar)  # the same layout, other values
    assert resolve_expert(str(path), CONFIG).name == "expert-trained"


def test_an_explicit_expert_is_every_drivers_and_without_it_each_its_own(tmp_path):
    """A policy file that records the style it learned from: evaluated against itself as --expert it agrees 1.0;
    without --expert it is compared with the style its file records, and the table names whom per driver."""
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    learner = tmp_path / "learner.npz"
    parameters = np.random.default_rng(5).normal(0, 1.0, shape.parameter_count)
    save_policy(Policy(shape, parameters), learner, {"observation_names": observation_names(CONFIG), "expert": "calm"})
    named = invoke("evaluate", *SMALL, "--expert", str(learner), "--policy", str(learner), "--policy", "keep",
                   "--episodes", "2", "--out", str(tmp_path / "named.parquet"))
    assert named.exit_code == 0, named.output
    metrics = pd.read_parquet(tmp_path / "named.parquet")
    assert (metrics["reference"] == "expert-learner").all()
    assert (metrics.loc[metrics["policy"] == "learner", "agreement"] == 1.0).all()
    assert "learner: 2 episodes, agreement with expert-learner" in named.output
    own = invoke("evaluate", *SMALL, "--policy", str(learner), "--policy", "keep", "--episodes", "2", "--out",
                 str(tmp_path / "own.parquet"))
    assert own.exit_code == 0, own.output
    metrics = pd.read_parquet(tmp_path / "own.parquet")
    by_driver = metrics.groupby("policy")["reference"].first().to_dict()
    assert by_driver == {"learner": "expert-calm", "keep": "expert-normal"}
    assert (metrics.loc[metrics["policy"] == "learner", "agreement"] < 1.0).any()
    assert "learner: 2 episodes, agreement with expert-calm" in own.output
    assert "keep was compared with another expert than learner" in own.output
    assert read_metadata(tmp_path / "own.parquet")["expert"] is None


def test_a_recorded_policy_expert_is_found_from_any_folder_and_a_changed_one_is_one_sentence(tmp_path,
                                                                                          monkeypatch):
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    monkeypatch.chdir(tmp_path)
    save_policy(Policy(shape, np.ones(shape.parameter_count)), Path("exp.npz"),
                {"observation_names": observation_names(CONFIG)})
    recorded = expert_reference("exp.npz")
    assert recorded.startswith(str(tmp_path / "exp.npz") + "#sha256=")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), Path("exp.npz"),
                {"observation_names": observation_names(CONFIG)})  # another policy of the same name here
    asked = resolve_expert(recorded, CONFIG, recorded_by="demos.parquet")
    assert np.array_equal(asked.policy.parameters, np.ones(shape.parameter_count))  # the recorded one
    save_policy(Policy(shape, np.full(shape.parameter_count, 2.0)), tmp_path / "exp.npz",
                {"observation_names": observation_names(CONFIG)})
    with pytest.raises(PolicyFileError, match=r"^the policy file .*exp\.npz, which demos\.parquet records as its "
                       r"expert, has changed since it was recorded \(its content hash differs\)$"):
        resolve_expert(recorded, CONFIG, recorded_by="demos.parquet")
    (tmp_path / "exp.npz").unlink()
    with pytest.raises(PolicyFileError, match=r"^the policy file .*exp\.npz, which demos\.parquet records as its "
                                              r"expert, does not exist$"):
        resolve_expert(recorded, CONFIG, recorded_by="demos.parquet")


def test_demonstrations_whose_expert_file_is_gone_are_one_sentence_naming_them(tmp_path, learned_expert):
    expert = tmp_path / "expert.npz"
    expert.write_bytes(learned_expert.read_bytes())
    demos = tmp_path / "demos.parquet"
    result = invoke("record-expert", *SMALL, "--expert", str(expert), "--episodes", "1", "--out", str(demos))
    assert result.exit_code == 0, result.output
    expert.unlink()
    for command in (("dagger", "--rounds", "1", "--set", "dagger.episodes_per_round=1"), ("train", "--iterations",
                    "1")):
        result = invoke(*command, *SMALL, "--demos", str(demos), "--set", "bc.epochs=1", "--eval-every", "0",
                        "--out", str(tmp_path / command[0]))
        assert result.exit_code == 1 and "Traceback" not in result.output, result.output
        assert f"which {demos} records as its expert, does not exist" in result.output


@pytest.mark.parametrize("setting, other", [("lidar.range_m", "80.0"), ("env.v_max_mps", "30.0"),
                                            ("env.v_min_mps", "5.0")])
def test_every_scale_setting_is_checked_against_a_policy_file_from_the_cli(tmp_path, setting, other):
    path = tmp_path / "trained.npz"
    shape = PolicyShape("linear", len(observation_names(CONFIG)))
    save_policy(Policy(shape, np.zeros(shape.parameter_count)), path,
                {"observation_names": observation_names(CONFIG), "config": CONFIG.to_dict()})
    section, key = setting.split(".")
    trained = CONFIG.to_dict()[section][key]
    for option in ("--policy", "--expert"):
        result = invoke("evaluate", *SMALL, "--set", f"{setting}={other}", option, str(path), "--episodes", "1")
        assert result.exit_code == 1 and "Traceback" not in result.output, result.output
        assert (f"reads observations scaled otherwise than this configuration's; it was trained with --set "
                f"{setting}={trained} and this configuration has {setting}={float(other)}") in result.output


def test_the_agreement_reward_asks_the_policy_file_the_demonstrations_recorded(tmp_path):
    """The same demonstrations, once as recorded (by a policy file that always keeps its action) and once said to be
    the normal style's: the agreement reward of the same first iteration differs, so it asks whom the file names."""
    from test_cli import SMALL as ROAD
    from test_cli import hand_made_policy

    from sumo_rail.datasets import read_table, write_parquet

    keeper = hand_made_policy(tmp_path / "keeper.npz", action=0)
    demos = tmp_path / "demos.parquet"
    assert invoke("record-expert", *ROAD, "--expert", str(keeper), "--episodes", "2", "--out",
                  str(demos)).exit_code == 0
    restyled = tmp_path / "restyled.parquet"
    write_parquet(read_table(demos), restyled, {**read_metadata(demos), "expert": "normal"})
    returns = []
    for name in (demos, restyled):
        run = tmp_path / name.stem
        result = invoke("train", *ROAD, "--demos", str(name), "--set", "rail.reward=agreement", "--set",
                        "network.shape=linear",
                        "--set", "bc.epochs=2", "--set", "rail.directions=2", "--iterations", "1", "--eval-every",
                        "0", "--out",
                        str(run))
        assert result.exit_code == 0, result.output
        returns.append(pd.read_parquet(run / "log.parquet")["return_mean"].item())
    assert returns[0] != returns[1]


def test_a_recorded_expert_that_is_no_style_nor_file_names_the_file_that_records_it(tmp_path):
    with pytest.raises(PolicyFileError, match=r"^demos\.parquet records the expert 'reckless', which is neither"):
        resolve_expert("reckless", CONFIG, recorded_by="demos.parquet")
    with pytest.raises(ValueError, match="unknown expert 'reckless'"):
        resolve_expert("reckless", CONFIG)  # typed by a user: a usage error
