"""Every option of `train` does what it says: it reaches run.json under its own name (a dropped or swapped option
fails), and the remedies change the iteration they are given to (the same run with one option changed differs)."""

import dataclasses
import json

import numpy as np
import pytest
from test_cli import SMALL, invoke

from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.trainer import RunSettings, train
from sumo_rail.runners.backends import SerialBackend

OPTIONS = {  # option: (value, where run.json's settings hold it, the value stored there); values all distinct
    "--policy": ("linear", ("kind",), "linear"), "--hidden": ("7", ("hidden",), 7),
    "--bc-epochs": ("2", ("bc_epochs",), 2), "--bc-class-balance": ("0.3", ("bc_class_balance",), 0.3),
    "--directions": ("4", ("rail", "directions"), 4), "--top": ("3", ("rail", "top"), 3),
    "--step-size": ("0.011", ("rail", "step_size"), 0.011),
    "--noise": ("0.012", ("rail", "noise", "initial"), 0.012),
    "--noise-increment": ("0.0013", ("rail", "noise", "increment"), 0.0013),
    "--noise-every": ("5", ("rail", "noise", "every"), 5),
    "--fitness": ("rank", ("rail", "fitness"), "rank"), "--reward": ("agreement", ("rail", "reward"), "agreement"),
    "--traffic": ("common", ("rail", "common_traffic"), True),
    "--episodes-per-rollout": ("6", ("rail", "episodes_per_rollout"), 6), "--egos": ("8", ("rail", "egos"), 8),
    "--merge-normalizer": (None, ("rail", "freeze_normalizer"), False),
    "--disc-hidden": ("9", ("discriminator", "hidden"), 9), "--disc-lr": ("0.014", ("discriminator", "learning_rate"),
                                                                          0.014),
    "--disc-steps": ("11", ("discriminator", "steps_per_iteration"), 11),
    "--disc-reward": ("contrast", ("discriminator", "reward_form"), "contrast"),
    "--disc-balance": ("0.15", ("discriminator", "balance"), 0.15),
    "--disc-penalty": ("0.16", ("discriminator", "gradient_penalty"), 0.16),
    "--disc-replay": ("12", ("discriminator", "replay"), 12),
    "--seed": ("13", ("rail", "seed"), 13),
    "--roads": ("straight, straight", ("rail", "roads"), ["straight", "straight"]),
}


@pytest.fixture(scope="module")
def demos(request):
    """test_training's demonstrations (by name: the imported fixture)."""
    return request.getfixturevalue("demos_path")


@pytest.fixture(scope="module")
def config(request):
    """test_training's small road."""
    return request.getfixturevalue("small_config_module")


def test_every_option_reaches_run_json_under_its_own_name(tmp_path, demos):
    options = [part for option, (value, _, _) in OPTIONS.items() for part in (option, *([value] * (value is not None)))]
    result = invoke("train", *SMALL, "--demos", str(demos), *options, "--iterations", "1", "--eval-every", "0",
                    "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    settings = json.loads((tmp_path / "run" / "run.json").read_text())["settings"]
    for option, (_, path, stored) in OPTIONS.items():
        found = settings
        for key in path:
            found = found[key]
        assert found == stored, option
    assert settings["discriminator"]["seed"] == 13 and settings["demos"] == str(demos)


BASE = RunSettings("", "linear", 4, 1, RailSettings(directions=2, top=2, step_size=0.05, seed=1),
                   DiscriminatorSettings(seed=1, steps_per_iteration=2))
CHANGES = {
    "--fitness rank": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, fitness="rank")),
    "--disc-reward contrast": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, reward_form="contrast")),
    "--disc-steps 5": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, steps_per_iteration=5)),
    "--traffic common": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, common_traffic=True)),
    "--egos 2": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, egos=2)),
    "--episodes-per-rollout 2": lambda s: dataclasses.replace(
        s, rail=dataclasses.replace(s.rail, episodes_per_rollout=2)),
    "--reward agreement": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, reward="agreement")),
    "--disc-balance 1": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, balance=1.0)),
    "--disc-penalty 1": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, gradient_penalty=1.0)),
    "--disc-hidden 8": lambda s: dataclasses.replace(s, discriminator=dataclasses.replace(s.discriminator, hidden=8)),
    "--disc-lr 0.01": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, learning_rate=0.01)),
}


class RecordingBackend(SerialBackend):
    """Runs tasks as SerialBackend does and keeps the names of their types, with the egos of a road's rollouts
    (RolloutTask x K)."""

    def __init__(self) -> None:
        super().__init__()
        self.task_types: set[str] = set()

    def run(self, tasks, on_result=None):
        self.task_types |= {type(task).__name__ + (f" x {len(task.members)}" if hasattr(task, "members") else "")
                            for task in tasks}
        return super().run(tasks, on_result)


def one_iteration(folder, settings, config) -> tuple[np.ndarray, set[str]]:
    with RecordingBackend() as backend:
        state = train(folder, settings, config, 1, backend, resume=False)
    return state.parameters, backend.task_types


@pytest.fixture(scope="module")
def base_iteration(tmp_path_factory, demos, config):
    return one_iteration(tmp_path_factory.mktemp("base") / "run", dataclasses.replace(BASE, demos=str(demos)), config)


@pytest.mark.parametrize("change", sorted(CHANGES))
def test_each_remedy_changes_the_iteration(tmp_path, demos, config, base_iteration, change):
    base_parameters, base_tasks = base_iteration
    parameters, tasks = one_iteration(tmp_path / "run", CHANGES[change](dataclasses.replace(BASE, demos=str(demos))),
                                      config)
    assert not np.array_equal(parameters, base_parameters)
    assert ("RolloutTask x 2" in tasks) == (change == "--egos 2") and "RolloutTask x 2" not in base_tasks
    assert "RolloutTask x 1" in base_tasks


def test_the_options_defaults_are_the_settings_dataclasses():
    """Each default is written once, in RailSettings and DiscriminatorSettings: the options read them."""
    from sumo_rail_cli.commands import train_command
    from sumo_rail_cli.search_options import SearchOptions

    context = train_command.make_context("train", ["--demos", "d.parquet", "--out", "run"])
    search = SearchOptions(**{field.name: context.params[field.name] for field in dataclasses.fields(SearchOptions)})
    assert search.settings(seed=5) == (RailSettings(seed=5), DiscriminatorSettings(seed=5))
