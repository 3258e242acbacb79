"""Everything made from a road keeps working on every road that is not straight (issue 35): demonstrations recorded
with several workers are the bytes of one, Minari exports and loads them back, `train` (RAIL) and `dagger` resume
exactly, and `evaluate --video` films the road. The clients' checks of the envs are in tests/sim/test_every_road.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sumo_rail_cli.main import cli

from sumo_rail.config import Config
from sumo_rail.drivers.expert import make_expert
from sumo_rail.evaluation.evaluate import Evaluation, evaluate
from sumo_rail.learning.bc import BcSettings
from sumo_rail.learning.dagger import DaggerSettings, train_dagger
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.trainer import RunSettings, train
from sumo_rail.learning.validation import Validation
from sumo_rail.runners.backends import ProcessPoolBackend, SerialBackend
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import ExpertDriver
from sumo_rail.runners.video import read_frames
from sumo_rail.seeding import Purpose, episode_seeds
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.render import EGO

KINDS = ["merge", "merge_from_ramp", "lane_drop", "exit"]
"""Every generated road that is not straight."""
FEATURE = {"feature_at_m": 750.0, "feature_length_m": 250.0}
"""tests/sim/test_scenarios.py's feature of the small road: past its start window, 400 m before its end."""
RESUMED_KIND = "exit"
"""The road of the (heavier) resume tests: the ego's route leaves the main road."""
SMALL = {"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3, "snapshot_interval_s": 10.0, **FEATURE},
         "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
         "observation": {"lane_block": 1, "route_block": 1}}
"""The small road of tests/conftest.py with test_scenarios's feature and the route-aware observation."""


def road(kind: str) -> Config:
    return Config.from_dict({**SMALL, "scenario": {**SMALL["scenario"], "kind": kind}})


def as_set_options(config: Config) -> list[str]:
    """`--set` options giving `config`'s small road on the command line."""
    return [part for section, values in SMALL.items() for key, value in values.items()
            for part in ("--set", f"{section}.{key}={value}")] + ["--set", f"scenario.kind={config.scenario.kind}"]


@pytest.fixture(scope="module")
def pool():
    """Two workers, kept for every road's recording."""
    with ProcessPoolBackend(2) as backend:
        yield backend


@pytest.fixture(scope="module", params=KINDS)
def recorded(request, pool, tmp_path_factory) -> dict[str, Path]:
    """The normal expert's three episodes of a road recorded with one worker ("one") and with two ("two"), and the
    road's kind."""
    config = road(request.param)
    folder = tmp_path_factory.mktemp(f"demos_{request.param}")
    paths = {"one": folder / "one.parquet", "two": folder / "two.parquet"}
    with SerialBackend() as serial:
        record_demonstrations(config, ExpertDriver("normal"), "normal", 4, 3, serial, paths["one"])
    record_demonstrations(config, ExpertDriver("normal"), "normal", 4, 3, pool, paths["two"])
    return {**paths, "kind": request.param}


def test_demonstrations_with_two_workers_are_the_bytes_of_one(recorded):
    table = pq.read_table(recorded["one"])
    assert table.num_rows > 60 and len(set(table.column("episode").to_pylist())) == 3
    assert recorded["one"].read_bytes() == recorded["two"].read_bytes()


def test_minari_exports_a_roads_demonstrations_and_loads_them_back(recorded, tmp_path):
    minari = pytest.importorskip("minari", reason="the Minari export is the package's optional extra [minari]")
    from sumo_rail.runners.minari_export import export_minari

    demos = recorded["one"]
    summary = export_minari(demos, "sumo-rail/road-v0", root=tmp_path)
    table = pq.read_table(demos).to_pandas()
    assert (summary.episodes, summary.steps) == (3, len(table))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
        dataset = minari.load_dataset("sumo-rail/road-v0")
        assert dataset.total_episodes == 3 and dataset.total_steps == len(table)
        for episode, (_, rows) in zip(dataset.iterate_episodes(), table.groupby("episode"), strict=True):
            rows = rows.sort_values("step")
            assert np.array_equal(episode.observations[:-1], np.stack(rows.observation.to_numpy()))
            assert np.array_equal(episode.actions, rows.action.to_numpy())
            assert episode.terminations[-1] == rows.terminated.iloc[0]
        env = dataset.recover_environment()  # the road travels with the dataset
    try:
        assert env.unwrapped.config == road(recorded["kind"])
        first = table[table.episode == 0].sort_values("step")
        observation, _ = env.reset(seed=int(first.episode_seed.iloc[0]))
        assert np.array_equal(observation, first.observation.iloc[0])  # the same road, the same episode
    finally:
        env.close()


def rail_settings(demos: Path) -> RunSettings:
    return RunSettings(str(demos), "mlp", 4, RailSettings(directions=2, top=1, step_size=0.01, seed=1),
                       DiscriminatorSettings(seed=1, steps_per_iteration=2), BcSettings(epochs=3))


def policy_arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as stored:
        return {name: stored[name] for name in stored.files}


def assert_same_policy(left: Path, right: Path) -> None:
    first, second = policy_arrays(left), policy_arrays(right)
    assert first.keys() == second.keys() and all(np.array_equal(first[name], second[name]) for name in first)
    assert left.read_bytes() == right.read_bytes()


@pytest.fixture(scope="module")
def resumed_demos(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("resumed_demos") / "demos.parquet"
    with SerialBackend() as serial:
        record_demonstrations(road(RESUMED_KIND), ExpertDriver("normal"), "normal", 0, 2, serial, path)
    return path


def test_rail_training_interrupted_after_iteration_1_resumes_to_the_same_policy(tmp_path, resumed_demos):
    config, settings = road(RESUMED_KIND), rail_settings(resumed_demos)
    with SerialBackend() as backend:
        train(tmp_path / "one", settings, config, 2, backend, resume=False, validation=Validation(0))
        train(tmp_path / "split", settings, config, 1, backend, resume=False, validation=Validation(0))
        train(tmp_path / "split", settings, config, 2, backend, resume=True, validation=Validation(0))
    assert_same_policy(tmp_path / "one" / "policy_latest.npz", tmp_path / "split" / "policy_latest.npz")
    assert pq.read_table(tmp_path / "one" / "log.parquet").num_rows == 2
    assert not np.array_equal(policy_arrays(tmp_path / "one" / "policy_latest.npz")["parameters"],
                              policy_arrays(tmp_path / "one" / "policy_bc.npz")["parameters"])  # it did learn


def test_dagger_interrupted_after_round_1_resumes_to_the_same_policy(tmp_path, resumed_demos):
    config = road(RESUMED_KIND)
    settings = DaggerSettings(str(resumed_demos), "mlp", 4, episodes_per_round=1,
                              bc=BcSettings(epochs=3, class_balance=0.75))
    with SerialBackend() as backend:
        train_dagger(tmp_path / "one", settings, config, 2, backend, resume=False, validation=Validation(0))
        train_dagger(tmp_path / "split", settings, config, 1, backend, resume=False, validation=Validation(0))
        train_dagger(tmp_path / "split", settings, config, 2, backend, resume=True, validation=Validation(0))
    assert_same_policy(tmp_path / "one" / "policy_latest.npz", tmp_path / "split" / "policy_latest.npz")
    assert pq.read_table(tmp_path / "one" / "dataset.parquet").num_rows > pq.read_table(resumed_demos).num_rows


TIME_LIMIT = ["--set", "env.max_episode_s=8"]
"""16 decisions an episode: the videos' frames are compared one by one."""


@pytest.fixture(scope="module", params=KINDS)
def filmed(request, pool) -> tuple[Config, Evaluation]:
    """The expert's first evaluation episode of a road (seed 5, 16 decisions) with its video."""
    config = road(request.param).with_overrides({"env": {"max_episode_s": 8.0}})
    return config, evaluate([ExpertDriver("normal")], config, episode_seeds(Purpose.EVALUATE, 5, 1), pool,
                            video_episodes=1)


def test_evaluation_videos_film_the_road_as_the_env_draws_it(filmed, tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="videos need the extra [video]")
    config, evaluation = filmed
    metrics = evaluation.metrics.iloc[0]
    (name, video), = evaluation.videos.items()
    (tmp_path / name).write_bytes(video)
    frames = read_frames(tmp_path / name)
    assert len(frames) == metrics.steps + 1 == 17  # the reset, then one frame per decision until the time limit
    env = HighwayEnv(config)
    expert = make_expert("normal", config.env.speed_step_mps, config.expert.view_range_m)
    try:  # evaluate's first episode: its seed, on the first warm state of the test pool
        observation, _ = env.reset(seed=int(metrics.seed), options={"pool": "test", "warm_state": 0})
        drawn = [env.frame()]
        for _ in range(metrics.steps):
            observation, *_ = env.step(expert(observation, env.traffic))
            drawn.append(env.frame())
    finally:
        env.close()
    assert {frame.shape for frame in frames} == {drawn[0].shape}
    for index, frame in enumerate(frames):  # the env's own frame of that decision, up to the video's compression
        difference = np.abs(frame.astype(np.int16) - drawn[index]).mean()
        assert difference < 3.0 and difference < np.abs(frame.astype(np.int16) - drawn[index - 1]).mean()
    assert all((np.abs(frame.astype(int) - np.array(EGO)).sum(axis=2) < 60).sum() > 20 for frame in frames)


@pytest.mark.parametrize("filmed", [RESUMED_KIND], indirect=True)
def test_evaluate_video_writes_the_roads_video(filmed, tmp_path):
    """The command (its own worker) writes the very video the library made."""
    config, evaluation = filmed
    videos, out = tmp_path / "videos", tmp_path / "metrics.parquet"
    result = CliRunner().invoke(cli, ["evaluate", "--policy", "expert", "--episodes", "1", "--seed", "5",
                                      *as_set_options(config), *TIME_LIMIT, "--video", str(videos), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {path.name: path.read_bytes() for path in videos.iterdir()} == evaluation.videos
