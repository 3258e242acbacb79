"""Every setting of `train` does what it says: it reaches run.json under its own name (a dropped or swapped one fails),
a bad one is refused naming it, and the remedies change the iteration they are given to (the same run with one
setting changed differs)."""

import dataclasses
import json

import numpy as np
import pytest
from test_cli import SMALL, invoke

from sumo_rail.learning.bc import BcSettings
from sumo_rail.learning.rail.discriminator import DiscriminatorSettings
from sumo_rail.learning.rail.iteration import RailSettings
from sumo_rail.learning.rail.trainer import RunSettings, train
from sumo_rail.runners.backends import SerialBackend

SETTINGS = {  # --set word: (where run.json's settings hold it, the value stored there); values all distinct
    "network.shape=linear": (("kind",), "linear"), "network.hidden=7": (("hidden",), 7),
    "bc.epochs=2": (("bc", "epochs"), 2), "bc.class_balance=0.3": (("bc", "class_balance"), 0.3),
    "bc.batch_size=17": (("bc", "batch_size"), 17), "bc.learning_rate=0.0021": (("bc", "learning_rate"), 0.0021),
    "bc.holdout_fraction=0.22": (("bc", "holdout_fraction"), 0.22),
    "rail.directions=4": (("rail", "directions"), 4), "rail.top=3": (("rail", "top"), 3),
    "rail.step_size=0.011": (("rail", "step_size"), 0.011),
    "rail.noise.initial=0.012": (("rail", "noise", "initial"), 0.012),
    "rail.noise.increment=0.0013": (("rail", "noise", "increment"), 0.0013),
    "rail.noise.every=5": (("rail", "noise", "every"), 5),
    "rail.fitness=rank": (("rail", "fitness"), "rank"), "rail.reward=agreement": (("rail", "reward"), "agreement"),
    "rail.common_traffic=true": (("rail", "common_traffic"), True),
    "rail.episodes_per_rollout=6": (("rail", "episodes_per_rollout"), 6), "rail.egos=8": (("rail", "egos"), 8),
    "rail.freeze_normalizer=false": (("rail", "freeze_normalizer"), False),
    "rail.flip_rate=0.07": (("rail", "flip_rate"), 0.07),
    "discriminator.hidden=9": (("discriminator", "hidden"), 9),
    "discriminator.learning_rate=0.014": (("discriminator", "learning_rate"), 0.014),
    "discriminator.steps_per_iteration=11": (("discriminator", "steps_per_iteration"), 11),
    "discriminator.batch_size=19": (("discriminator", "batch_size"), 19),
    "discriminator.reward_clip=0.0021": (("discriminator", "reward_clip"), 0.0021),
    "discriminator.reward_form=contrast": (("discriminator", "reward_form"), "contrast"),
    "discriminator.balance=0.15": (("discriminator", "balance"), 0.15),
    "discriminator.gradient_penalty=0.16": (("discriminator", "gradient_penalty"), 0.16),
    "discriminator.replay=12": (("discriminator", "replay"), 12),
}
OPTIONS = {"--seed": ("13", ("rail", "seed"), 13),
           "--roads": ("straight, straight", ("rail", "roads"), ["straight", "straight"])}


@pytest.fixture(scope="module")
def demos(request):
    """test_training's demonstrations (by name: the imported fixture)."""
    return request.getfixturevalue("demos_path")


@pytest.fixture(scope="module")
def config(request):
    """test_training's small road."""
    return request.getfixturevalue("small_config_module")


def stored(settings: dict, path: tuple[str, ...]):
    for key in path:
        settings = settings[key]
    return settings


def test_every_setting_reaches_run_json_under_its_own_name(tmp_path, demos):
    """Each --set word and option lands where it says (a dropped or swapped one fails), the run's seed in every
    section that draws; a [section] table of --config does the same."""
    words = [part for word in SETTINGS for part in ("--set", word)]
    options = [part for option, (value, _, _) in OPTIONS.items() for part in (option, value)]
    result = invoke("train", *SMALL, "--demos", str(demos), *words, *options, "--iterations", "1", "--eval-every", "0",
                    "--out", str(tmp_path / "run"))
    assert result.exit_code == 0, result.output
    settings = json.loads((tmp_path / "run" / "run.json").read_text())["settings"]
    for word, (path, value) in SETTINGS.items():
        assert stored(settings, path) == value, word
    for option, (_, path, value) in OPTIONS.items():
        assert stored(settings, path) == value, option
    assert settings["discriminator"]["seed"] == settings["bc"]["seed"] == 13 and settings["demos"] == str(demos)


def test_config_tables_set_the_learners_settings(tmp_path):
    """[rail], [rail.noise], [discriminator], [bc] and [network] tables of --config reach the command, --set after them
    wins; a table of another learner is left for its command; a --set of it is refused."""
    from sumo_rail_cli.settings import resolve_settings

    path = tmp_path / "run.toml"
    path.write_text("[rail]\ndirections = 8\nstep_size = 0.5\n[rail.noise]\nevery = 3\n[discriminator]\n"
                    "reward_form = \"contrast\"\n[bc]\nepochs = 4\n[network]\nshape = \"linear\"\n"
                    "[ppo]\nent_coef = 0.5\n[scenario]\nlanes = 4\n")
    config, settings = resolve_settings("paper", path, ("rail.directions=6",), ("network", "bc", "rail",
                                                                                "discriminator"))
    assert config.scenario.lanes == 4
    assert (settings.rail.directions, settings.rail.step_size, settings.rail.noise.every) == (6, 0.5, 3)
    assert settings.discriminator.reward_form == "contrast" and settings.bc.epochs == 4
    assert settings.network.shape == "linear" and "ppo" not in settings.sections
    assert settings.chosen >= {"rail.directions", "rail.noise.every", "bc.epochs"}
    result = invoke("train", "--demos", "x.parquet", "--set", "ppo.ent_coef=0.5", "--out", str(tmp_path / "run"))
    assert result.exit_code == 2 and "[ppo]" in result.output and "Traceback" not in result.output


def test_settings_valid_only_together_may_come_from_the_file_and_from_set(tmp_path):
    """The file's tables and the --set words are merged before any check: a file's rail.top that fits only the
    directions --set gives, and a file's start window that fits only the road --set lengthens, are taken."""
    from sumo_rail_cli.settings import resolve_settings

    path = tmp_path / "run.toml"
    path.write_text("[rail]\ntop = 40\n[env]\nego_start_max_m = 3500\n")
    config, settings = resolve_settings("paper", path, ("rail.directions=64", "scenario.length_m=5000"),
                                        ("network", "bc", "rail", "discriminator"))
    assert (settings.rail.top, settings.rail.directions) == (40, 64)
    assert (config.env.ego_start_max_m, config.scenario.length_m) == (3500, 5000)


@pytest.mark.parametrize(("word", "named"), [
    ("rail.directions=0", "rail.directions"), ("rail.directions=4.5", "rail.directions must be an integer"),
    ("rail.seed=3", "--seed"), ("rail.roads=[]", "--roads"), ("rail.nope=1", "rail.nope"),
    ("rail.noise.initial=0", "rail.noise.initial"), ("rail.noise=1", "rail.noise is a table"),
    ("discriminator.reward_form=other", "discriminator.reward_form"), ("bc.class_balance=-1", "bc.class_balance"),
    ("network.shape=cnn", "network.shape"), ("rail.common_traffic=1", "true or false"),
    ("rail.top=5", "rail.top must be between 1 and rail.directions"), ("rail", "SECTION.KEY=VALUE")])
def test_a_bad_setting_is_refused_in_one_sentence_naming_it(tmp_path, word, named):
    result = invoke("train", "--demos", "x.parquet", "--set", "rail.directions=4", "--set", word, "--out",
                    str(tmp_path / "run"))
    assert result.exit_code == 2 and named in result.output and "Traceback" not in result.output, result.output
    assert not (tmp_path / "run").exists()


def test_help_settings_lists_every_setting_with_its_default_and_help():
    from sumo_rail.learning.bc import BcSettings
    from sumo_rail.learning.rail.iteration import RailSettings

    result = invoke("train", "--help-settings")
    assert result.exit_code == 0, result.output
    assert f"rail.directions = {RailSettings().directions}" in result.output
    assert f"bc.class_balance = {BcSettings().class_balance}" in result.output
    assert "rail.noise.every = 10" in result.output and "N, directions per iteration" in result.output
    assert "scenario.lanes = 5" in result.output and "rail.seed" not in result.output and "[ppo]" not in result.output


BASE = RunSettings("", "linear", 4, RailSettings(directions=2, top=2, step_size=0.05, seed=1),
                   DiscriminatorSettings(seed=1, steps_per_iteration=2), BcSettings(epochs=1, seed=1))
CHANGES = {
    "rail.fitness=rank": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, fitness="rank")),
    "discriminator.reward_form=contrast": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, reward_form="contrast")),
    "discriminator.steps_per_iteration=5": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, steps_per_iteration=5)),
    "rail.common_traffic=true": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, common_traffic=True)),
    "rail.egos=2": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, egos=2)),
    "rail.episodes_per_rollout=2": lambda s: dataclasses.replace(
        s, rail=dataclasses.replace(s.rail, episodes_per_rollout=2)),
    "rail.reward=agreement": lambda s: dataclasses.replace(s, rail=dataclasses.replace(s.rail, reward="agreement")),
    "discriminator.balance=1": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, balance=1.0)),
    "discriminator.gradient_penalty=1": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, gradient_penalty=1.0)),
    "discriminator.hidden=8": lambda s: dataclasses.replace(
        s, discriminator=dataclasses.replace(s.discriminator, hidden=8)),
    "discriminator.learning_rate=0.01": lambda s: dataclasses.replace(
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
    assert ("RolloutTask x 2" in tasks) == (change == "rail.egos=2") and "RolloutTask x 2" not in base_tasks
    assert "RolloutTask x 1" in base_tasks


def test_the_commands_defaults_are_the_settings_dataclasses():
    """Each default is written once, in the settings dataclasses: a command without a setting runs with them."""
    from sumo_rail_cli.settings import resolve_settings

    _, settings = resolve_settings("paper", None, (), ("network", "bc", "rail", "discriminator"))
    assert settings.rail == RailSettings() and settings.discriminator == DiscriminatorSettings()
    assert settings.bc == BcSettings()
