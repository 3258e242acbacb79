"""evaluate --policy sampled:PATH: a policy file evaluated by sampling from its softmax, seeded per episode."""

from dataclasses import replace

import numpy as np
import pandas as pd
from test_cli import SMALL, SMALL_CONFIG, hand_made_policy, invoke

from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.policies import Policy, PolicyShape, save_policy
from sumo_rail.runners.experts import parse_policy
from sumo_rail.runners.rollout import PolicyDriver
from sumo_rail.seeding import driver_generator
from sumo_rail.sim.observation import observation_names


def test_a_sampled_driver_repeats_itself_per_seed_and_draws_apart_from_the_env():
    shape = PolicyShape("linear", 4)
    driver = PolicyDriver(Policy(shape, np.zeros(shape.parameter_count)), "flat", sampled=True)
    observation = np.zeros(4)

    def actions(seed: int) -> list[int]:
        act = driver.create(None, seed)
        return [act(observation, None) for _ in range(40)]

    assert actions(7) == actions(7) != actions(8)
    assert not np.array_equal(driver_generator(7).random(8), np.random.default_rng(7).random(8))  # env's stream
    assert set(actions(7)) == set(range(5))
    argmax = PolicyDriver(driver.policy, "flat").create(None, 7)
    assert {argmax(observation, None) for _ in range(40)} == {0}


def test_sampled_evaluation_is_the_same_for_any_worker_count_and_differs_from_argmax(tmp_path):
    policy = hand_made_policy(tmp_path / "mostly_keep.npz", action=0)  # logits 1 vs 0: argmax keeps, softmax 40%
    outs = [tmp_path / "m1.parquet", tmp_path / "m2.parquet"]
    for out, workers in zip(outs, ("1", "2"), strict=True):
        result = invoke("evaluate", *SMALL, "--policy", str(policy), "--policy", f"sampled:{policy}", "--episodes",
                        "2", "--seed", "1000", "--workers", workers, "--out", str(out))
        assert result.exit_code == 0, result.output
        assert "mostly_keep (sampled)" in result.output
    frames = [pd.read_parquet(out) for out in outs]
    pd.testing.assert_frame_equal(frames[0], frames[1])
    pd.testing.assert_frame_equal(*(pd.read_parquet(out.with_suffix(".decisions.parquet")) for out in outs))
    assert frames[0]["policy"].tolist() == ["mostly_keep"] * 2 + ["mostly_keep (sampled)"] * 2
    assert read_metadata(outs[0])["policies"] == [str(policy), f"sampled:{policy}"]
    decisions = pd.read_parquet(outs[0].with_suffix(".decisions.parquet"))
    argmax = decisions[decisions["policy"] == "mostly_keep"]["action"]
    sampled = decisions[decisions["policy"] == "mostly_keep (sampled)"]["action"]
    assert (argmax == 0).all()
    assert 0.25 < (sampled == 0).mean() < 0.55 and set(sampled) == set(range(5))


def test_a_lower_sampling_temperature_draws_nearer_the_argmax_and_names_itself(tmp_path):
    path = hand_made_policy(tmp_path / "mostly_keep.npz", action=0)  # logits 1 vs 0: softmax 40% keep, at 1/4 93%
    observation = np.zeros(len(observation_names(SMALL_CONFIG)))
    shares, names = {}, {}
    for temperature in (1.0, 0.25):
        config = replace(SMALL_CONFIG, actions=replace(SMALL_CONFIG.actions, sampling_temperature=temperature))
        driver = parse_policy(path, config, sampled=True)
        act = driver.create(config, 7)
        shares[temperature] = np.mean([act(observation, None) == 0 for _ in range(400)])
        names[temperature] = driver.name
    assert 0.33 < shares[1.0] < 0.47 and shares[0.25] > 0.88
    assert names == {1.0: "mostly_keep (sampled)", 0.25: "mostly_keep (sampled at 0.25)"}


def test_a_bad_sampled_policy_file_is_one_sentence(tmp_path):
    result = invoke("evaluate", *SMALL, "--policy", f"sampled:{tmp_path / 'missing.npz'}")
    assert result.exit_code == 2 and "nor an existing policy file" in result.output and "Traceback" not in result.output


def test_a_sampled_policy_file_recording_a_bad_expert_is_named_by_its_path(tmp_path):
    """Without --expert a sampled driver is compared with the expert its file records, as the argmax one is; the
    error naming a bad recorded expert names the file, not the --policy word."""
    shape = PolicyShape("linear", len(observation_names(SMALL_CONFIG)))
    path = tmp_path / "learner.npz"
    save_policy(Policy(shape, np.zeros(shape.parameter_count, np.float32)), path,
                {"observation_names": observation_names(SMALL_CONFIG), "expert": "reckless"})
    for word in (str(path), f"sampled:{path}"):
        result = invoke("evaluate", *SMALL, "--policy", word, "--episodes", "1")
        assert result.exit_code == 1 and "Traceback" not in result.output, result.output
        assert f"Error: {path} records the expert 'reckless'" in result.output, result.output
