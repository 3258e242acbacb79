"""Every learner's settings in one place: the sections `network`, `bc`, `rail`, `discriminator`, `dagger`, `gail` and
`ppo`, each a frozen settings dataclass of the learner's own module (its fields' docstrings are the help, their
defaults the defaults), changed by a command's `--config` tables and `--set SECTION.KEY=VALUE` words
(`LearnerSettings.with_tables`) and stored whole in the run's run.json.

A field a command fills itself (the seed, the demonstrations, the roads, the network's shape inside a learner's own
dataclass) is `bounds.given`: it is no setting of its section, and setting it names where it comes from."""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from sumo_rail.bounds import ConfigError, bounded, check_fields, replace_settings
from sumo_rail.drivers.policies import KINDS


@dataclass(frozen=True)
class NetworkSettings:
    """The policy network every learner trains (`drivers.policies.PolicyShape`)."""

    shape: str = "mlp"
    """linear: observation -> one logit per action (5, or 3 x bins under the acceleration interface); mlp:
    observation -> network.hidden tanh units -> the logits."""
    hidden: int = bounded(1, 4096, default=10)
    """Hidden units of the mlp shape, between 1 and 4096."""

    def __post_init__(self) -> None:
        if self.shape not in KINDS:
            raise ConfigError(f"network.shape must be one of {', '.join(KINDS)}, got {self.shape!r}")
        check_fields(self, "network.")


SECTIONS: dict[str, str] = {
    "network": "sumo_rail.learning.settings:NetworkSettings",
    "bc": "sumo_rail.learning.bc:BcSettings",
    "rail": "sumo_rail.learning.rail.iteration:RailSettings",
    "discriminator": "sumo_rail.learning.rail.discriminator:DiscriminatorSettings",
    "dagger": "sumo_rail.learning.dagger:DaggerSettings",
    "gail": "sumo_rail.learning.sb3.gail:GailSettings",
    "ppo": "sumo_rail.learning.sb3.ppo:PpoSettings",
}
"""Each learner section's settings dataclass, "module:Class", imported only by the commands that take it."""


def section_class(name: str) -> type:
    """The settings dataclass of the learner section `name`."""
    module, owner = SECTIONS[name].split(":")
    return getattr(importlib.import_module(module), owner)


def default_section(name: str) -> Any:
    """The learner section `name` with its defaults (a required `given` field, such as the demonstrations, empty)."""
    cls = section_class(name)
    required = {item.name: "" for item in dataclasses.fields(cls)
                if item.default is dataclasses.MISSING and item.default_factory is dataclasses.MISSING}
    return cls(**required)


@dataclass(frozen=True)
class LearnerSettings:
    """The learner sections one command takes, as set (`section("rail")` or `.rail`), and the dotted keys a user gave
    (`chosen`: a command may pick another default where the user chose none)."""

    sections: Mapping[str, Any]
    chosen: frozenset[str] = field(default_factory=frozenset)

    @classmethod
    def defaults(cls, names: tuple[str, ...]) -> LearnerSettings:
        return cls({name: default_section(name) for name in names})

    def __getattr__(self, name: str) -> Any:
        sections = self.__dict__.get("sections", {})
        if name in sections:
            return sections[name]
        raise AttributeError(name)

    def with_tables(self, tables: Mapping[str, Any]) -> LearnerSettings:
        """A copy with the `{section: {key: value}}` of `tables` replaced; a section this command does not take, an
        unknown key or a bad value is a one-sentence ConfigError."""
        unknown = sorted(set(tables) - set(self.sections))
        if unknown:
            raise ConfigError(f"this command has no [{unknown[0]}] settings; its learner settings are "
                              f"{', '.join(f'[{name}]' for name in self.sections)}")
        sections = dict(self.sections)
        for name, values in tables.items():
            if not isinstance(values, Mapping):
                raise ConfigError(f"config section [{name}] must be a table, got {values!r}")
            sections[name] = replace_settings(name, sections[name], values)
        return LearnerSettings(sections, self.chosen | frozenset(_dotted(tables)))

    def to_dict(self) -> dict[str, Any]:
        return {name: dataclasses.asdict(section) for name, section in self.sections.items()}


def _dotted(tables: Mapping[str, Any], prefix: str = "") -> list[str]:
    keys = []
    for key, value in tables.items():
        keys += _dotted(value, f"{prefix}{key}.") if isinstance(value, Mapping) else [f"{prefix}{key}"]
    return keys
