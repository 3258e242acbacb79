import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

from sumo_rail.datasets import read_metadata
from sumo_rail.drivers.expert import make_expert
from sumo_rail.runners.backends import ProcessPoolBackend, SerialBackend
from sumo_rail.runners.dart import ActionNoise
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import ExpertDriver, run_episode
from sumo_rail.sim.env import HighwayEnv


def test_the_noise_replaces_about_epsilon_of_the_actions_and_repeats_with_the_seed():
    noise = ActionNoise(0.3)
    perturb = noise.perturbation(7)
    executed = np.array([perturb(0) for _ in range(4000)])
    # a replaced action is uniform over the five, so it differs from the decided one with probability 0.3 x 4/5
    assert np.mean(executed != 0) == pytest.approx(0.24, abs=0.02)
    assert set(executed.tolist()) == {0, 1, 2, 3, 4}
    again = noise.perturbation(7)
    assert [again(0) for _ in range(4000)] == executed.tolist()
    assert [ActionNoise(0.0).perturbation(7)(3) for _ in range(100)] == [3] * 100
    with pytest.raises(ValueError, match=r"in \[0, 1\)"):
        ActionNoise(1.0)


def test_labels_are_the_experts_decision_in_the_state_the_perturbed_car_is_in(small_config):
    expert = make_expert("normal", small_config.env.speed_step_mps, small_config.expert.view_range_m)
    executed, asked = [], []

    def perturb(action: int) -> int:
        executed.append(ActionNoise(0.5).perturbation(len(executed))(action))  # a fresh draw each decision
        return executed[-1]

    env = HighwayEnv(small_config)
    try:
        result = run_episode(env, expert, seed=3, record=True, perturb=perturb,
                             probe=lambda observation, traffic, *_: asked.append(expert(observation, traffic)))
    finally:
        env.close()
    labels = result.steps["action"].tolist()
    assert labels == asked  # every label is what the expert decides in the traffic the car is really in
    assert sum(label != done for label, done in zip(labels, executed, strict=True)) > 5  # and the car did otherwise
    set_points = result.steps["set_point_mps"]
    band = abs(set_points - 30.5) > 1.0
    assert band[len(band) // 2:].any()  # the noise moves the car off the expert's set-point band after its start


def test_a_noisy_recording_stores_its_noise_and_is_the_same_on_two_workers(small_config, tmp_path):
    noise = ActionNoise(0.2)
    with SerialBackend() as backend:
        record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 2, backend, tmp_path / "a.parquet",
                              noise=noise)
        record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 2, backend, tmp_path / "b.parquet")
        with pytest.raises(ValueError, match="one ego"):
            record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 2, backend,
                                  tmp_path / "c.parquet", egos=2, noise=noise)
    with ProcessPoolBackend(2) as pool:
        record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 2, pool, tmp_path / "d.parquet",
                              noise=noise)
    assert pq.read_table(tmp_path / "d.parquet").equals(pq.read_table(tmp_path / "a.parquet"))
    metadata = read_metadata(tmp_path / "a.parquet")
    assert metadata["dart"]["epsilon"] == 0.2 and metadata["dart"]["form"] == "random_action"
    assert "dart" not in read_metadata(tmp_path / "b.parquet")
    noisy, plain = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert noisy.column("set_point_mps").to_pylist() != plain.column("set_point_mps").to_pylist()


def test_dart_noise_with_several_egos_is_a_usage_error(tmp_path):
    result = CliRunner().invoke(cli, ["record-expert", "--dart-noise", "0.1", "--egos", "2", "--episodes", "2",
                                      "--out", str(tmp_path / "demos.parquet")])
    assert result.exit_code == 2 and "--dart-noise records one ego per episode" in result.output
    assert not (tmp_path / "demos.parquet").exists()
