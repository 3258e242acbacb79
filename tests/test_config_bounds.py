"""Every number a user can set (--set, --config, a dict given to gymnasium.make) has a range a road, a car or a clock
can have, declared once with its field and stated in its docstring; NaN, infinities and values outside it are one
sentence naming the setting and its range. The fields are found by walking Config, so a new one cannot escape."""

import ast
import dataclasses
import inspect
import math
import re
from pathlib import Path

import click
import pytest
from sumo_rail_cli.settings import resolve_settings

import sumo_rail.config
from sumo_rail.bounds import Bounds, bounds_of, check_fields
from sumo_rail.config import PRESETS, Config, ConfigError


def numeric_fields() -> list[tuple[str, dataclasses.Field]]:
    """(section, field) for every int or float setting of every section of Config."""
    return [(section.name, field) for section in dataclasses.fields(Config)
            for field in dataclasses.fields(section.default_factory)
            if type(field.default) in (int, float)]


FIELDS = numeric_fields()
IDS = [f"{section}.{field.name}" for section, field in FIELDS]


def test_the_walk_finds_the_settings_the_issue_names():
    assert {"scenario.speed_limit_mps", "scenario.lane_width_m", "env.zip_merge_m", "scenario.warmup_s",
            "scenario.lanes", "lidar.beams", "observation.route_range_m", "expert.view_range_m"} <= set(IDS)


@pytest.mark.parametrize(("section", "field"), FIELDS, ids=IDS)
def test_every_number_has_a_finite_range_holding_its_default(section, field):
    bounds = bounds_of(field)
    assert isinstance(bounds, Bounds), f"{section}.{field.name} has no range"
    assert math.isfinite(bounds.low) and math.isfinite(bounds.high) and bounds.low < bounds.high
    assert bounds.holds(field.default)


@pytest.mark.parametrize(("section", "field"), FIELDS, ids=IDS)
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 1e12, -1e12])
def test_a_value_no_one_could_mean_is_one_sentence_naming_the_setting(section, field, value):
    if isinstance(field.default, int) and math.isfinite(value):
        value = int(value)
    with pytest.raises(ConfigError) as caught:
        Config.from_dict({section: {field.name: value}})
    message = str(caught.value)
    assert message.startswith(f"{section}.{field.name} must be ") and "\n" not in message
    if isinstance(field.default, float):  # integers' NaN is "must be an integer"
        assert bounds_of(field).describe() in message


@pytest.mark.parametrize(("section", "field"), FIELDS, ids=IDS)
def test_the_range_s_ends_are_as_stated(section, field):
    """A closed end is accepted, an open end and a step beyond either end refused (the range check alone: the
    relations between settings, such as v_min below v_max, are checked after it)."""
    bounds, defaults = bounds_of(field), getattr(Config(), section)
    step = 1 if isinstance(field.default, int) else 1e-6 * (bounds.high - bounds.low)

    def accepted(value: float) -> bool:
        try:
            check_fields(dataclasses.replace(defaults, **{field.name: type(field.default)(value)}))
        except ConfigError:
            return False
        return True

    assert accepted(bounds.low) is not bounds.low_open and accepted(bounds.high) is not bounds.high_open
    assert accepted(bounds.low + step) and accepted(bounds.high - step)
    assert not accepted(bounds.low - step) and not accepted(bounds.high + step)


def test_every_docstring_states_its_range():
    """The range a user reads in the field's docstring is the one checked."""
    modules = {inspect.getsourcefile(type(getattr(Config(), section))) for section, _ in FIELDS}
    trees = [ast.parse(Path(module).read_text()) for module in sorted(modules)]
    docstrings = {}
    for node in [node for tree in trees for node in tree.body if isinstance(node, ast.ClassDef)]:
        for annotated, following in zip(node.body, node.body[1:], strict=False):
            if isinstance(annotated, ast.AnnAssign) and isinstance(following, ast.Expr):
                docstrings[(node.name, annotated.target.id)] = " ".join(following.value.value.split())
    for section, field in FIELDS:
        owner = type(getattr(Config(), section)).__name__
        assert bounds_of(field).describe() in docstrings[(owner, field.name)], f"{section}.{field.name}"


def test_defaults_and_presets_pass():
    for name in PRESETS:
        check_fields(Config.preset(name))


def test_direct_construction_is_checked_too():
    with pytest.raises(ConfigError, match=re.escape("scenario.lane_width_m must be a finite number between 2 and 5 m, "
                                                    "got nan")):
        Config(scenario=sumo_rail.config.ScenarioConfig(lane_width_m=math.nan))


@pytest.mark.parametrize(("setting", "message"), [
    ("scenario.speed_limit_mps=1000", "scenario.speed_limit_mps must be above 0 and at most 70 m/s, got 1000"),
    ("scenario.lane_width_m=50", "scenario.lane_width_m must be between 2 and 5 m, got 50"),
    ("env.zip_merge_m=-100", "env.zip_merge_m must be between 0 and 1000 m, got -100"),
    ("scenario.warmup_s=1e8", "scenario.warmup_s must be between 0 and 3600 s, got 100000000"),
    ("env.v_max_mps=nan", "env.v_max_mps must be a finite number above 0 and at most 70 m/s, got nan"),
])
def test_the_issue_s_values_are_usage_errors(tmp_path, setting, message):
    with pytest.raises(click.UsageError) as caught:
        resolve_settings("paper", None, (f"{setting}",))[0]
    assert caught.value.message == message
    toml = tmp_path / "c.toml"
    key, value = setting.split("=")
    section, name = key.split(".")
    toml.write_text(f"[{section}]\n{name} = {value}\n")
    with pytest.raises(click.UsageError) as caught:
        resolve_settings("paper", toml, ())[0]
    assert caught.value.message == message


def test_the_set_point_range_must_be_a_range():
    """v_min < v_max: equal ends would leave the longitudinal reward and the set-point's feature 0 / 0."""
    assert Config.from_dict({"env": {"v_min_mps": 29.9, "v_max_mps": 30.0}}).env.v_min_mps == 29.9
    with pytest.raises(ConfigError, match=re.escape("env.v_min_mps and env.v_max_mps must satisfy 0 <= v_min < v_max, "
                                                    "got 30.0 and 30.0")):
        Config.from_dict({"env": {"v_min_mps": 30.0, "v_max_mps": 30.0}})


def test_an_episode_lasts_at_least_one_decision_period():
    assert Config.from_dict({"env": {"max_episode_s": 0.5, "decision_period_s": 0.5}}).env.max_episode_s == 0.5
    with pytest.raises(ConfigError, match=re.escape("env.max_episode_s must be at least one decision period, "
                                                    "got 0.4")):
        Config.from_dict({"env": {"max_episode_s": 0.4, "decision_period_s": 0.5}})


def test_a_warm_up_of_days_is_refused_though_each_of_its_settings_is_in_range():
    """scenario.snapshots and scenario.snapshot_interval_s each in range can still ask for a warm-up of 69 simulated
    days a pool (about 14 hours of SUMO each); the largest pool at the default interval and the longest warm-up is
    taken."""
    sentence = ("scenario.warmup_s + (scenario.snapshots - 1) x scenario.snapshot_interval_s (5999700 s) must be "
                "at most 200000 s, the simulated time of a pool of warm states (about half an hour of SUMO)")
    with pytest.raises(click.UsageError) as caught:
        resolve_settings("paper", None, ("scenario.snapshots=10000", "scenario.snapshot_interval_s=600"))
    assert caught.value.message == sentence
    config = Config.from_dict({"scenario": {"snapshots": 10_000, "warmup_s": 3600}})
    assert config.scenario.snapshots == 10_000
