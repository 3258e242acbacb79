"""Settings as a user writes them: `--set SECTION.KEY=VALUE` words read into `{section: {key: value}}` tables (the
form of a `--config` TOML file), and every setting of a group of settings dataclasses listed with its value and the
help its docstring gives (`--help-settings`)."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import itertools
import textwrap
import tomllib
from collections.abc import Iterable, Mapping
from functools import cache
from typing import Any

from sumo_rail.bounds import ConfigError, bounds_of, given_by


def read_assignments(words: Iterable[str]) -> dict[str, Any]:
    """`SECTION.KEY=VALUE` words as nested tables, later words winning; a KEY may itself be dotted for a table inside
    the section ("rail.noise.initial=0.05"). VALUE is TOML (numbers, true/false, quoted strings, lists); a bare word
    is a string. A malformed word raises a one-sentence ConfigError."""
    tables: dict[str, Any] = {}
    for word in words:
        key, separator, raw = word.partition("=")
        path = [part.strip() for part in key.split(".")]
        if not separator or len(path) < 2 or not all(path):
            raise ConfigError(f"--set expects SECTION.KEY=VALUE, got {word!r}")
        raw = raw.strip()
        try:
            value = tomllib.loads(f"value = {raw}")["value"]
        except tomllib.TOMLDecodeError as error:
            if not raw or raw[0] in "\"'[{":
                raise ConfigError(f"--set {key.strip()} has an unreadable value {raw!r}") from error
            value = raw  # bare words (scenario.kind=merge, a file's path, a route's edges) are a string
        table = tables
        for part in path[:-1]:
            table = table.setdefault(part, {})
            if not isinstance(table, dict):
                raise ConfigError(f"--set {key.strip()}: {part} is a setting, not a table of settings")
        table[path[-1]] = value
    return tables


def merged_tables(first: Mapping[str, Any], then: Mapping[str, Any]) -> dict[str, Any]:
    """The tables of `first` with those of `then` merged in, table by table, a value of `then` winning."""
    merged = dict(first)
    for key, value in then.items():
        both = isinstance(value, Mapping) and isinstance(merged.get(key), Mapping)
        merged[key] = merged_tables(merged[key], value) if both else value
    return merged


def field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of the dataclass `cls` (and of its bases), by field name."""
    docs: dict[str, str] = {}
    for owner in reversed(cls.__mro__):
        if dataclasses.is_dataclass(owner):
            docs.update(_own_field_docs(owner))
    return docs


@cache
def _own_field_docs(cls: type) -> dict[str, str]:
    try:
        definition = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0]
    except (OSError, TypeError):
        return {}
    assert isinstance(definition, ast.ClassDef)  # the source of a class is its class statement
    docs = {}
    for field, after in itertools.pairwise(definition.body):
        if (isinstance(field, ast.AnnAssign) and isinstance(field.target, ast.Name) and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):
            docs[field.target.id] = " ".join(after.value.value.split())
    return docs


def settings_listing(sections: Mapping[str, Any]) -> str:
    """Every setting of `sections` ({name: settings dataclass}) as `name.key = value` lines, each followed by its
    help (the field's docstring, and its range when `bounded` gave one); fields a command fills itself are left
    out."""
    lines: list[str] = []
    for name, section in sections.items():
        lines += ["", f"[{name}]", *_section_lines(name, section)]
    return "\n".join(lines[1:])


def _section_lines(prefix: str, section: Any) -> list[str]:
    lines: list[str] = []
    docs = field_docs(type(section))
    for field in dataclasses.fields(section):
        if given_by(field) is not None:
            continue
        value, key = getattr(section, field.name), f"{prefix}.{field.name}"
        if dataclasses.is_dataclass(value):
            lines += _section_lines(key, value)
            continue
        help_text = docs.get(field.name, "")
        if (bounds := bounds_of(field)) is not None and bounds.describe() not in help_text:
            help_text = f"{help_text} ({bounds.describe()})".strip()
        lines.append(f"  {key} = {_toml(value)}")
        lines += [f"      {line}" for line in textwrap.wrap(help_text, 100)]
    return lines


def _toml(value: Any) -> str:
    """A value as --set and TOML take it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml(item) for item in value) + "]"
    return "(unset)" if value is None else f"{value:g}" if isinstance(value, float) else str(value)
