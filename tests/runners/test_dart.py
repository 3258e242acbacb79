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
from sumo_rail.runners.rollout import ExpertDriver, KeepDriver, run_shared_episode
from sumo_rail.sim.actions import Action
from sumo_rail.sim.parallel_env import ParallelHighwayEnv


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
    asked, executed = [], []
    noise = ActionNoise(0.5).perturbation(3)

    def watched_expert(observation, traffic):
        asked.append(expert(observation, traffic))
        return asked[-1]

    def perturb(action: int) -> int:
        executed.append(noise(action))
        return executed[-1]

    env = ParallelHighwayEnv(1, small_config)
    try:
        result, = run_shared_episode(env, [watched_expert], seed=3, record=True, perturbs=[perturb])
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
    with ProcessPoolBackend(2) as pool:
        record_demonstrations(small_config, ExpertDriver("normal"), "normal", 0, 2, pool, tmp_path / "d.parquet",
                              noise=noise)
    assert pq.read_table(tmp_path / "d.parquet").equals(pq.read_table(tmp_path / "a.parquet"))
    metadata = read_metadata(tmp_path / "a.parquet")
    assert metadata["dart"]["epsilon"] == 0.2 and metadata["dart"]["form"] == "random_action"
    assert "dart" not in read_metadata(tmp_path / "b.parquet")
    noisy, plain = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert noisy.column("set_point_mps").to_pylist() != plain.column("set_point_mps").to_pylist()


def test_several_egos_each_execute_their_own_noise_and_record_the_drivers_actions(small_config, tmp_path):
    out = tmp_path / "demos.parquet"
    with SerialBackend() as backend:
        record_demonstrations(small_config, KeepDriver(), "keep", 0, 2, backend, out, egos=2,
                              noise=ActionNoise(0.3))
    table = pq.read_table(out).to_pandas()
    metadata = read_metadata(out)
    assert metadata["egos"] == 2 and metadata["dart"]["epsilon"] == 0.3
    assert table["episode"].nunique() == 2
    assert (table["action"] == 0).all()  # every record is the driver's "keep"
    for _, episode in table.groupby("episode"):  # while each car's set-point moved with its own noise
        assert episode["set_point_mps"].nunique() > 1


def test_dart_noise_with_several_egos_is_accepted_by_the_command(tmp_path):
    out = tmp_path / "demos.parquet"
    result = CliRunner().invoke(cli, ["record-expert", "--dart-noise", "0.1", "--egos", "2", "--episodes", "2",
                                      "--set", "scenario.length_m=1500", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert read_metadata(out)["egos"] == 2 and read_metadata(out)["dart"]["epsilon"] == 0.1


def test_each_ego_of_a_shared_road_draws_its_noise_from_its_own_episode_s_stream(small_config, tmp_path):
    """A driver that always keeps: every set-point change is a noisy accelerate or decelerate, so each ego's changes
    fall exactly where the noise stream of its own episode seed put one (most of them: at the speed bounds a step
    changes nothing). Every ego on ego 0's stream changes where that stream says, not where its own does."""
    out = tmp_path / "demos.parquet"
    noise = ActionNoise(0.3)
    with SerialBackend() as backend:
        record_demonstrations(small_config, KeepDriver(), "keep", 0, 2, backend, out, egos=2, noise=noise)
    table = pq.read_table(out).to_pandas()
    for _, rows in table.groupby("episode"):
        perturb = noise.perturbation(int(rows["episode_seed"].iloc[0]))
        executed = [perturb(0) for _ in range(len(rows))]
        drawn = {step for step, action in enumerate(executed[:-1]) if action in (Action.ACCELERATE, Action.DECELERATE)}
        changed = set(np.flatnonzero(np.diff(rows["set_point_mps"].to_numpy()) != 0).tolist())
        assert changed <= drawn and len(changed) >= len(drawn) / 2, (sorted(changed), sorted(drawn))
