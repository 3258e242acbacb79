"""Every number of every learner section (network, bc, rail, discriminator, dagger, gail, ppo, their nested tables
and the optional ones) has a range a run can use, declared once with its field (`bounds.bounded`): --set, --config
and --help-settings show and enforce it. The fields are found by walking the sections, so a new one cannot escape."""

import dataclasses
import itertools
import math

import click
import pytest
from click.testing import CliRunner
from learner_numbers import learner_numbers
from sumo_rail_cli.main import cli

from sumo_rail.bounds import Bounds, ConfigError, bounds_of
from sumo_rail.learning.settings import LearnerSettings, default_section
from sumo_rail.setting_tables import read_assignments

NUMBERS = learner_numbers()
IDS = [key for key, _, _ in NUMBERS]


def with_value(key: str, value: object) -> LearnerSettings:
    section = key.split(".")[0]
    return LearnerSettings.defaults((section,)).with_tables(read_assignments([f"{key}={value}"]))


def test_the_walk_finds_every_kind_of_learner_number():
    assert {"network.hidden", "bc.epochs", "rail.directions", "rail.top", "rail.step_size", "rail.noise.initial",
            "rail.rollout_decisions", "rail.flip_rate", "discriminator.steps_per_iteration", "dagger.beta",
            "gail.batch_size", "ppo.n_steps", "ppo.batch_size"} <= set(IDS)


@pytest.mark.parametrize(("key", "field", "kind"), NUMBERS, ids=IDS)
def test_every_learner_number_has_a_finite_range_holding_its_default(key, field, kind):
    bounds = bounds_of(field)
    assert isinstance(bounds, Bounds), f"{key} has no range"
    assert math.isfinite(bounds.low) and math.isfinite(bounds.high) and bounds.low < bounds.high
    assert bounds.integer == (kind is int), key
    section, *path = key.split(".")
    default = default_section(section)
    for name in path:  # a nested table's field too
        default = getattr(default, name)
    assert default is None or bounds.holds(default), key


@pytest.mark.parametrize(("key", "field", "kind"), NUMBERS, ids=IDS)
def test_a_value_beyond_either_end_is_one_sentence_naming_the_setting_and_its_range(key, field, kind):
    bounds = bounds_of(field)
    step = 1 if kind is int else 1e-6 * (bounds.high - bounds.low)
    for value in (bounds.high + step, bounds.low - step, 10 * bounds.high + 1e9):
        value = int(value) if kind is int else value
        with pytest.raises(ConfigError) as caught:
            with_value(key, value)
        message = str(caught.value)
        assert message.startswith(f"{key} must be {bounds.describe()}, got ") and "\n" not in message, message


@pytest.mark.parametrize("command", ["train", "dagger", "gail", "ppo", "step-signal"])
def test_help_settings_shows_every_range(command):
    result = CliRunner().invoke(cli, [command, "--help-settings"])
    assert result.exit_code == 0, result.output
    helps: dict[str, str] = {}  # each setting's line and the help indented under it
    for line in result.output.splitlines():
        if line.startswith("  ") and not line.startswith("      "):
            key = line.split(" = ")[0].strip()
            helps[key] = line
        elif line.startswith("      "):
            helps[key] += line
    taken = [(key, field) for key, field, _ in NUMBERS if f"[{key.split('.')[0]}]" in result.output]
    assert taken
    for key, field in taken:
        assert bounds_of(field).describe() in " ".join(helps[key].split()), key


@pytest.mark.parametrize(("word", "sentence"), [
    ("rail.directions=1000000000", "rail.directions must be between 1 and 4096, got 1000000000"),
    ("rail.step_size=1e30", "rail.step_size must be above 0 and at most 1, got 1e+30"),
])
def test_the_issue_s_values_are_refused_in_one_sentence_before_any_work(tmp_path, word, sentence):
    for how in (["--set", word], ["--config", str(tmp_path / "run.toml")]):
        section, rest = word.split(".", 1)
        (tmp_path / "run.toml").write_text(f"[{section}]\n{rest.replace('=', ' = ')}\n")
        result = CliRunner().invoke(cli, ["train", "--demos", str(tmp_path / "demos.parquet"), *how,
                                          "--out", str(tmp_path / "run")])
        assert result.exit_code == 2, result.output
        errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
        assert errors == [f"Error: {sentence}"], result.output
        assert "Traceback" not in result.output and not (tmp_path / "run").exists()


def after(flag: str, words: list[str]) -> tuple[str, ...]:
    """The words that follow `flag` in `words`."""
    return tuple(value for word, value in itertools.pairwise(words) if word == flag)


def committed_spec_commands() -> list[tuple[str, str, str, tuple[str, ...]]]:
    """(spec, command, preset, --set words) of every sumo-rail step of every committed experiment spec as it runs by
    default (words holding a value read when the step runs left out), and of each axis value kept out by default,
    its --set words alone (the specs say which values they combine with)."""
    from test_grid import ROOT, grid

    found = []
    for path in sorted((ROOT / "experiments" / "specs").glob("*.toml")):
        spec = grid.read_spec(path)
        for step in grid.expand(spec, path, {}):
            if step.command[:1] == ("sumo-rail",):
                words = list(step.command)
                found.append((path.name, words[1], (*after("--preset", words), "paper")[0],
                              tuple(word for word in after("--set", words) if "{" not in word)))
        for step in spec.get("step", []):
            command = step.get("command", [])
            for axis in grid.named_axes(command) if command[:1] == ["sumo-rail"] else ():
                for value in spec.get("axes", {}).get(axis, []):
                    if isinstance(value, dict) and value.get("default") is False:
                        words = [str(word) for word in value.get("args", [])]
                        found.append((path.name, command[1], "paper", after("--set", words)))
    return found


def test_every_committed_spec_s_settings_are_in_range():
    from sumo_rail_cli.settings import resolve_settings

    commands = committed_spec_commands()
    assert any("rail.directions=512" in sets for _, _, _, sets in commands)
    for spec, command, preset, sets in commands:
        learners = [param.callback.keywords["learners"] for param in cli.commands[command].params
                    if param.name == "help_settings"]
        if not learners:
            continue
        try:
            _, settings = resolve_settings(preset, None, sets, learners[0])
            if command == "dagger":  # what the command adds to its [dagger] section
                dataclasses.replace(settings.dagger, bc=settings.bc)
        except (click.UsageError, ValueError) as error:
            raise AssertionError(f"{spec}: {command} {' '.join(sets)}: {error}") from error


@pytest.mark.parametrize("section", ["gail", "ppo"])
def test_a_ppo_update_that_would_not_fit_in_memory_is_refused(section):
    """Each of n_steps, envs and egos in range can still make an update of 2 billion decisions, which PPO keeps in
    memory at once."""
    with pytest.raises(ConfigError) as caught:
        LearnerSettings.defaults((section,)).with_tables(read_assignments(
            [f"{section}.n_steps=1000000", f"{section}.envs=2"]))
    assert str(caught.value) == (f"an update must hold at most 1000000 decisions ({section}.n_steps x {section}.envs x "
                                 f"{section}.egos), got 2000000")
    with_value(f"{section}.n_steps", 500_000)  # with the default 2 envs: 1000000, taken
