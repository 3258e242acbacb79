"""DAgger on the small scenario: labels are the expert's, the dataset aggregates, and the result does not depend
on workers or on an interruption."""

import json
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from test_cli import SMALL, invoke

from sumo_rail.config import Config
from sumo_rail.drivers.expert import make_expert
from sumo_rail.drivers.policies import Policy, PolicyShape, load_policy
from sumo_rail.learning import dagger
from sumo_rail.learning.bc import BcReport, BcSettings
from sumo_rail.learning.dagger import DaggerSettings, DaggerTask, train_dagger
from sumo_rail.learning.run_folder import RunError
from sumo_rail.learning.validation import Validation
from sumo_rail.runners.backends import ProcessPoolBackend, SerialBackend, WorkerContext
from sumo_rail.runners.rollout import EpisodeTask, ExpertDriver, PolicyDriver, run_episode
from sumo_rail.runners.tables import DEMONSTRATIONS, Demonstrations, demonstrations_table, provenance
from sumo_rail.sim.actions import Action

CONFIG = Config.from_dict({"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3,
                                        "snapshot_interval_s": 10.0},
                           "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0}})


@pytest.fixture(scope="module")
def demos(tmp_path_factory):
    from sumo_rail.datasets import write_parquet

    path = tmp_path_factory.mktemp("dagger_demos") / "demos.parquet"
    seeds = [0, 3]
    with SerialBackend() as backend:
        results = backend.run([EpisodeTask(CONFIG, ExpertDriver("normal"), s, record=True) for s in seeds])
    write_parquet(demonstrations_table(results, seeds, 56), path,
                  provenance(DEMONSTRATIONS, CONFIG, 0, style="normal"))
    return path


def settings(demos, **changes) -> DaggerSettings:
    return DaggerSettings(str(demos), "mlp", 4, bc=BcSettings(epochs=3, class_balance=0.75),
                          **{"episodes_per_round": 2, **changes})


def test_labels_are_the_experts_whoever_drives(tmp_path, demos, monkeypatch):
    with SerialBackend() as backend:
        (expert_only,), = backend.run([DaggerTask(CONFIG, going_left_policy(), ExpertDriver("normal"), 1.0, (5,))])
        recorded, = backend.run([EpisodeTask(CONFIG, ExpertDriver("normal"), 5, record=True)])
    assert expert_only.policy_decisions == 0
    assert np.array_equal(expert_only.labels, recorded.steps["action"])  # the expert drove: labels = its actions
    assert np.array_equal(expert_only.observations, recorded.steps["observation"])

    # The learner drives every decision (beta 0): the states it visits, which the expert's own driving does not lead
    # to, enter the aggregated dataset labelled with what the expert would do there, never with its own action.
    learner = going_left_policy()
    monkeypatch.setattr(dagger, "behaviour_cloning", lambda data, shape, bc: (learner, BC_REPORT))
    backend = TaskRecordingBackend()
    with backend:
        train_dagger(tmp_path / "run", settings(demos, episodes_per_round=1, beta=0.0, seed=2), CONFIG, 1, backend,
                     resume=False, validation=Validation(0))
        task, = backend.tasks
        assert task.policy is learner and task.beta == 0.0
        driven, = backend.run([LearnerAskingTheExpert(CONFIG, learner, "normal", task.seeds[0])])
    dataset = pq.read_table(tmp_path / "run" / "dataset.parquet")
    new = np.array(dataset.column("episode").to_pylist()) > max(pq.read_table(demos).column("episode").to_pylist())
    observations = np.stack(dataset.column("observation").to_pylist())[new]
    labels = np.array(dataset.column("action").to_pylist())[new]
    assert np.array_equal(observations, driven["observation"])  # the learner's very states
    assert np.array_equal(labels, driven["expert"])  # labelled with the expert's decisions there
    assert len(set(labels)) > 1  # (this seed's traffic asks the expert for more than one action)
    assert set(driven["action"]) == {Action.LANE_LEFT} and Action.LANE_LEFT not in labels  # never the learner's


BC_REPORT = BcReport(train_accuracy=0.0, holdout_accuracy=None, losses=[], train_rows=0, holdout_rows=0)


def going_left_policy() -> Policy:
    """A policy that always changes to the left lane (only its bias is non-zero), which the expert never does at the
    states it leads to."""
    shape = PolicyShape("linear", 56)
    parameters = np.zeros(shape.parameter_count, np.float32)
    parameters[shape.actions * shape.observation_size + Action.LANE_LEFT] = 1.0
    return Policy(shape, parameters)


class TaskRecordingBackend(SerialBackend):
    """A serial backend that keeps the tasks of its last run."""

    def run(self, tasks, on_result=None):
        self.tasks = list(tasks)
        return super().run(tasks, on_result)


@dataclass(frozen=True)
class LearnerAskingTheExpert:
    """The recorded steps of the episode `policy` alone drives from `seed`, with the decision of the expert of `style`,
    asked apart from DAgger, in the traffic of each step ("expert")."""

    config: Config
    policy: Policy
    style: str
    seed: int

    def run(self, context: WorkerContext) -> dict[str, np.ndarray]:
        expert = make_expert(self.style, self.config.env.speed_step_mps, self.config.expert.view_range_m)
        env = context.env(self.config)
        with env.watching(ExpertAsked(expert)) as asked:
            steps = run_episode(env, PolicyDriver(self.policy, "learner").create(self.config, 0), self.seed,
                                record=True).steps
        return {**steps, "expert": np.array(asked.decisions)}


class ExpertAsked:
    """An observer of decisions asking `expert` what it would do in the traffic of each."""

    every_step = False

    def __init__(self, expert) -> None:
        self.expert, self.decisions = expert, []

    def __call__(self, moment) -> None:
        self.decisions += [int(self.expert.decide(decision.traffic)) for decision in moment.decisions()]


@pytest.mark.parametrize("egos", [1, 2])
def test_same_policy_with_one_or_two_workers_and_after_resuming(tmp_path, demos, egos):
    """With two egos a round's two episodes share one simulation."""
    run = settings(demos, egos=egos)
    with SerialBackend() as serial:
        train_dagger(tmp_path / "one", run, CONFIG, 2, serial, resume=False, validation=Validation(0))
    with ProcessPoolBackend(2) as two:
        train_dagger(tmp_path / "split", run, CONFIG, 1, two, resume=False, validation=Validation(0))
        train_dagger(tmp_path / "split", run, CONFIG, 2, two, resume=True, validation=Validation(0))
    uninterrupted, _ = load_policy(tmp_path / "one" / "policy_latest.npz")
    resumed, _ = load_policy(tmp_path / "split" / "policy_latest.npz")
    assert np.array_equal(uninterrupted.parameters, resumed.parameters)
    log = pd.read_parquet(tmp_path / "one" / "log.parquet")
    assert log["iteration"].tolist() == [0, 1, 2] and log["beta"].tolist() == [1.0, 0.5, 0.25]
    dataset = pq.read_table(tmp_path / "one" / "dataset.parquet")
    assert dataset.num_rows == log["dataset_rows"].iloc[-1] == log["dataset_rows"].iloc[0] + log["env_steps"].sum()
    assert len(set(dataset.column("episode").to_pylist())) == 2 + 2 * 2  # every ego's episode is labelled
    with pytest.raises(RunError, match="other settings"):
        train_dagger(tmp_path / "one", settings(demos, beta=0.9), CONFIG, 3, SerialBackend(), resume=True)


@pytest.mark.parametrize(("beta", "expert_drives"), [(1.0, True), (0.0, False)])
def test_in_a_shared_simulation_each_ego_follows_its_own_mixture(demos, beta, expert_drives):
    policy = Policy(PolicyShape("linear", 56), np.zeros(5 * 56 + 5, np.float32))
    task = DaggerTask(CONFIG, policy, ExpertDriver("normal"), beta, (5, 6, 7))
    context = WorkerContext()
    try:
        episodes = task.run(context)
    finally:
        context.close()
    assert len(episodes) == 3 and all(len(episode.labels) > 0 for episode in episodes)
    assert [episode.policy_decisions for episode in episodes] == [
        0 if expert_drives else len(episode.labels) for episode in episodes]


def test_dagger_command_end_to_end(tmp_path, demos):
    out = tmp_path / "run"
    result = invoke("dagger", *SMALL, "--demos", str(demos), "--rounds", "1", "--set", "dagger.episodes_per_round=1",
                    "--set", "bc.epochs=2", "--eval-episodes", "1", "--out", str(out))
    assert result.exit_code == 0, result.output
    assert "round 1:" in result.output and "validation agreement" in result.output
    assert sorted(path.name for path in out.iterdir()) == ["checkpoint.json", "dataset.parquet", "log.parquet",
                                                            "policy_bc.npz", "policy_latest.npz", "run.json"]
    result = invoke("evaluate", *SMALL, "--policy", str(out / "policy_latest.npz"), "--episodes", "1")
    assert result.exit_code == 0 and "run/policy_latest" in result.output
    again = invoke("dagger", *SMALL, "--demos", str(demos), "--rounds", "1", "--out", str(out))
    assert again.exit_code == 1 and "not empty" in again.output and "Traceback" not in again.output
    bad = invoke("dagger", *SMALL, "--demos", str(demos), "--set", "dagger.beta=1.5", "--out", str(tmp_path / "x"))
    assert bad.exit_code == 2


def test_the_dagger_defaults_are_its_settings():
    """Each default is written once, in DaggerSettings and Validation: the command reads them."""
    from sumo_rail_cli.dagger_command import dagger_command
    from sumo_rail_cli.settings import resolve_settings

    params = dagger_command.make_context("dagger", ["--demos", "d.parquet", "--out", "run"]).params
    assert resolve_settings("paper", None, (), ("dagger",))[1].dagger == DaggerSettings("")
    assert params["eval_episodes"] == Validation().episodes


def test_a_round_on_a_mix_of_roads_takes_the_roads_in_turn(tmp_path, demos):
    """`roads`: a round's simulations take the roads in turn, each labelled episode driven on its own road; a resumed
    run keeps its roads."""
    config = CONFIG.with_overrides({"scenario": {"feature_at_m": 700.0}})
    mixed = settings(demos, roads=("straight", "exit"), beta=1.0)  # the expert drives: each episode is its recording
    backend = TaskRecordingBackend()
    with backend:
        train_dagger(tmp_path / "run", mixed, config, 1, backend, resume=False, validation=Validation(0))
        assert [task.config.scenario.kind for task in backend.tasks] == ["straight", "exit"]
        seeds = [task.seeds[0] for task in backend.tasks]
        recorded = backend.run([EpisodeTask(config.with_overrides({"scenario": {"kind": road}}), ExpertDriver("normal"),
                                            seed, record=True) for road, seed in zip(mixed.roads, seeds, strict=True)])
        on_straight, = backend.run([EpisodeTask(config, ExpertDriver("normal"), seeds[1], record=True)])
    dataset = pq.read_table(tmp_path / "run" / "dataset.parquet").to_pandas()
    first = int(pq.read_table(demos).column("episode").to_numpy().max()) + 1
    for offset, episode in enumerate(recorded):
        labelled = np.stack(dataset[dataset["episode"] == first + offset]["observation"].to_list())
        assert np.array_equal(labelled, episode.steps["observation"])
    assert len(on_straight.steps["observation"]) != len(recorded[1].steps["observation"]) or not np.array_equal(
        on_straight.steps["observation"], recorded[1].steps["observation"])  # the exit's episode is not the straight's
    with SerialBackend() as serial:  # closed: its simulation runs in this process
        train_dagger(tmp_path / "run", mixed, config, 2, serial, resume=True, validation=Validation(0))
        with pytest.raises(RunError, match="other settings"):
            train_dagger(tmp_path / "run", settings(demos, beta=1.0), config, 3, serial, resume=True)


def test_an_unknown_road_in_the_mix_is_a_usage_error(tmp_path, demos):
    result = invoke("dagger", *SMALL, "--demos", str(demos), "--roads", "straight,roundabout", "--out",
                    str(tmp_path / "run"))
    assert result.exit_code == 2 and "unknown scenario.kind 'roundabout'" in result.output
    assert not (tmp_path / "run").exists()


def test_dagger_takes_the_network_settings_and_refuses_bc_without_epochs(tmp_path, demos):
    """network.hidden shapes DAgger's policies. bc.epochs=0 means no behaviour cloning for train and gail, but every
    DAgger policy is BC's (the first and each round's): dagger refuses it in one sentence, before any work, rather
    than training an epoch nobody asked for; the library refuses it too."""
    out = tmp_path / "run"
    refused = invoke("dagger", *SMALL, "--demos", str(demos), "--rounds", "0", "--set", "bc.epochs=0", "--out",
                     str(out))
    assert refused.exit_code == 2 and "Traceback" not in refused.output, refused.output
    errors = [line for line in refused.output.splitlines() if line.startswith("Error:")]
    assert errors == ["Error: dagger learns by behaviour cloning in every round, so bc.epochs must be at least 1 "
                      "for it, got 0"], refused.output
    assert not out.exists()
    with pytest.raises(ValueError, match=r"bc\.epochs must be at least 1"):
        DaggerSettings(str(demos), bc=BcSettings(epochs=0))
    result = invoke("dagger", *SMALL, "--demos", str(demos), "--rounds", "0", "--set", "bc.epochs=1", "--set",
                    "network.hidden=7", "--eval-every", "0", "--out", str(out))
    assert result.exit_code == 0, result.output
    stored = json.loads((out / "run.json").read_text())["settings"]
    assert stored["bc"]["epochs"] == 1 and stored["hidden"] == 7
    assert load_policy(out / "policy_bc.npz")[0].shape.hidden == 7


def test_a_round_of_actions_past_127_is_saved_as_labelled(tmp_path):
    """The acceleration interface's finer bins (0.05 m/s^2: 543 actions) give labels int8 cannot hold."""
    shape = PolicyShape("linear", 4, actions=543)
    labels = np.array([0, 200, 542])
    dataset = Demonstrations(np.zeros((3, 4), np.float32), labels, np.array([0, 0, 1]), {})
    dagger._save(tmp_path, 1, dataset, Policy(shape, np.zeros(shape.parameter_count)), [{"iteration": 1}], {})
    assert pq.read_table(tmp_path / "dataset.parquet").column("action").to_pylist() == labels.tolist()
