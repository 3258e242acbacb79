"""How a policy's logits become an action on the acceleration interface (`actions.decoding`): the lane decision by its
lateral marginal, then the mean (or median) bin of the acceleration given that decision; stored in the policy file,
argmax for files without it, refused on the paper interface."""

from __future__ import annotations

import numpy as np
import pytest

from sumo_rail.action_config import ActionConfig
from sumo_rail.bounds import ConfigError
from sumo_rail.config import Config
from sumo_rail.datasets import DatasetError
from sumo_rail.drivers.decoding import decode
from sumo_rail.drivers.policies import Policy, PolicyFileError, PolicyShape, load_policy, save_policy
from sumo_rail.runners.tables import interface_mismatch
from sumo_rail.sim.actions import Lateral, acceleration_action, split_acceleration_action

ACTIONS = ActionConfig(interface="acceleration")
BINS = ACTIONS.acceleration_bins
N = 4


def logits_of(weights: dict[tuple[float, Lateral], float]) -> np.ndarray:
    """Logits putting log-weight `weights[(acceleration, lateral)]` on those actions and nearly none elsewhere."""
    logits = np.full(len(Lateral) * BINS, -60.0)
    for (acceleration, lateral), value in weights.items():
        logits[acceleration_action(ACTIONS.nearest_bin(acceleration), lateral, ACTIONS)] = value
    return logits


def acceleration_of(action: int) -> tuple[float, Lateral]:
    acceleration_bin, lateral = split_acceleration_action(int(action), ACTIONS)
    return ACTIONS.acceleration_mps2(acceleration_bin), lateral


BIMODAL = logits_of({(0.0, Lateral.KEEP): np.log(0.4), (0.75, Lateral.KEEP): np.log(0.35),
                     (1.0, Lateral.KEEP): np.log(0.25)})
"""0 m/s^2 is the single most likely bin (0.4), the mean acceleration +0.5125 m/s^2, the median +0.75."""


def test_the_expected_decoding_takes_the_mean_bin_where_argmax_takes_the_mode():
    assert acceleration_of(decode(BIMODAL, "argmax")) == (0.0, Lateral.KEEP)
    assert acceleration_of(decode(BIMODAL, "expected")) == (0.5, Lateral.KEEP)  # +0.5125 snaps to +0.5, not +0.75
    assert acceleration_of(decode(BIMODAL, "median")) == (0.75, Lateral.KEEP)


def test_the_mean_snaps_to_the_nearest_bin_on_either_side():
    above = logits_of({(0.0, Lateral.KEEP): np.log(0.55), (0.25, Lateral.KEEP): np.log(0.45)})  # +0.1125: 0
    below = logits_of({(0.0, Lateral.KEEP): np.log(0.45), (0.25, Lateral.KEEP): np.log(0.55)})  # +0.1375: +0.25
    assert acceleration_of(decode(above, "expected"))[0] == 0.0
    assert acceleration_of(decode(below, "expected"))[0] == 0.25


def test_the_lateral_marginal_decides_the_lane_even_against_the_top_logit():
    """Keep holds the single most likely action (0.3), a change left the most probability (0.56 over two bins): the
    lane decision is left, its acceleration the mean of left's bins only."""
    logits = logits_of({(0.0, Lateral.KEEP): np.log(0.3), (0.5, Lateral.LEFT): np.log(0.27),
                        (1.5, Lateral.LEFT): np.log(0.29), (2.0, Lateral.RIGHT): np.log(0.14)})
    assert acceleration_of(decode(logits, "argmax")) == (0.0, Lateral.KEEP)
    assert acceleration_of(decode(logits, "expected")) == (1.0, Lateral.LEFT)  # (0.135 + 0.435) / 0.56 = +1.018
    assert acceleration_of(decode(logits, "median")) == (1.5, Lateral.LEFT)


def test_a_batch_decodes_row_by_row_as_one_observation_does():
    rows = np.stack([BIMODAL, logits_of({(-2.0, Lateral.RIGHT): 0.0}), np.linspace(-1, 1, 3 * BINS)])
    for decoding in ("argmax", "expected", "median"):
        assert list(decode(rows, decoding)) == [int(decode(row, decoding)) for row in rows]


def bias_policy(logits: np.ndarray, decoding: str = "argmax") -> Policy:
    """A linear policy of N observations whose logits are `logits` whatever it sees."""
    shape = PolicyShape("linear", N, actions=len(logits), decoding=decoding)
    parameters = np.concatenate([np.zeros(len(logits) * N), logits]).astype(np.float32)
    return Policy(shape, parameters)


def test_a_policy_acts_by_its_decoding_and_its_file_keeps_it(tmp_path):
    observations = np.zeros((3, N))
    for decoding in ("argmax", "expected", "median"):
        policy = bias_policy(BIMODAL, decoding)
        save_policy(policy, tmp_path / f"{decoding}.npz", {"note": decoding})
        loaded, metadata = load_policy(tmp_path / f"{decoding}.npz")
        assert loaded.shape.decoding == decoding and metadata == {"note": decoding}
        assert loaded.act(observations[0]) == int(decode(BIMODAL, decoding)) == policy.act(observations[0])
        assert list(loaded.acts(observations)) == [loaded.act(row) for row in observations]


def test_a_policy_file_without_a_decoding_acts_by_argmax(tmp_path):
    """A file written before the decoding existed holds no `decoding` field."""
    path = tmp_path / "old.npz"
    save_policy(bias_policy(BIMODAL), path, {})
    with np.load(path) as archive:
        assert "decoding" not in archive.files
    policy, _ = load_policy(path)
    assert policy.shape.decoding == "argmax" and acceleration_of(policy.act(np.zeros(N))) == (0.0, Lateral.KEEP)


def test_a_policy_file_with_an_unknown_decoding_is_one_sentence(tmp_path):
    path = tmp_path / "bad.npz"
    save_policy(bias_policy(BIMODAL, "expected"), path, {})
    with np.load(path) as archive:
        fields = {key: archive[key] for key in archive.files}
    np.savez(path, **{**fields, "decoding": np.array("mode")})
    with pytest.raises(PolicyFileError, match=r"bad.npz is inconsistent: unknown decoding 'mode'"):
        load_policy(path)


def test_the_paper_interface_refuses_a_decoding_other_than_argmax():
    for decoding in ("expected", "median"):
        refusal = rf"actions.decoding={decoding} reads a lane decision .* the paper interface's actions are decoded by"
        with pytest.raises(ConfigError, match=refusal):
            Config.from_dict({"actions": {"decoding": decoding}})
        with pytest.raises(ValueError, match="a policy of 5 actions is decoded by argmax"):
            PolicyShape("linear", N, decoding=decoding)
    chosen = Config.from_dict({"actions": {"interface": "acceleration", "decoding": "median"}})
    assert chosen.actions.decoding == "median"
    with pytest.raises(ConfigError, match=r"unknown actions.decoding 'mode'; known: argmax, expected, median"):
        Config.from_dict({"actions": {"interface": "acceleration", "decoding": "mode"}})


def test_demonstrations_of_the_interface_serve_a_run_of_any_decoding(tmp_path):
    """The decoding says how a policy reads its logits, not what an action is: demonstrations recorded under one
    decoding train a run of another, while another interface is still refused."""
    recorded = {"config": {"actions": {"interface": "acceleration"}}}  # written before the decoding existed
    for decoding in ("argmax", "expected", "median"):
        interface_mismatch(tmp_path / "demos.parquet", recorded, ActionConfig("acceleration", decoding=decoding))
    with pytest.raises(DatasetError, match="holds demonstrations of the acceleration interface"):
        interface_mismatch(tmp_path / "demos.parquet", recorded, ActionConfig())
