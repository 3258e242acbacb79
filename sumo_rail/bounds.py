"""The values a setting may take: the range of each number, declared once with its dataclass field (`bounded`) and
checked by `check_fields`, and the type a user's value must have (`replace_settings`, `coerce`); a field a command
fills itself is `given`. Errors are a one-sentence `ConfigError` naming the setting."""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


class ConfigError(ValueError):
    """A configuration value or file a user supplied is invalid (message is one sentence)."""


@dataclass(frozen=True)
class Bounds:
    """The finite range of a numeric setting [low, high], either end open, in `unit`; `integer`: whole numbers."""

    low: float
    high: float
    unit: str = ""
    low_open: bool = False
    high_open: bool = False
    integer: bool = False

    def holds(self, value: float) -> bool:
        """Whether `value` lies in the range (never NaN, never infinite)."""
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return bool(above and below)

    def describe(self) -> str:
        """The range in words, e.g. "above 0 and at most 70 m/s", "between 2 and 5 m", "0 or 1"."""
        low, high = _number(self.low), _number(self.high)
        unit = f" {self.unit}" if self.unit else ""
        if self.integer and self.high == self.low + 1:
            return f"{low} or {high}{unit}"
        if not (self.low_open or self.high_open):
            return f"between {low} and {high}{unit}"
        return (f"{'above' if self.low_open else 'at least'} {low} and "
                f"{'below' if self.high_open else 'at most'} {high}{unit}")


def bounded(low: float, high: float, unit: str = "", *, default: float | None, low_open: bool = False,
            high_open: bool = False, integer: bool | None = None, **field_options: Any) -> Any:
    """A numeric setting's dataclass field with its default and its range as metadata, e.g.
    `speed_limit_mps: float = bounded(0, 70, "m/s", default=33.33, low_open=True)`. An optional setting (default
    None: unset, never checked) says with `integer` whether it takes whole numbers; otherwise its default says it."""
    bounds = Bounds(low, high, unit, low_open, high_open, isinstance(default, int) if integer is None else integer)
    return dataclasses.field(default=default, metadata={"bounds": bounds}, **field_options)


def bounds_of(field: dataclasses.Field[Any]) -> Bounds | None:
    """The range `bounded` gave a field, if any."""
    return field.metadata.get("bounds")


def check_fields(settings: Any, prefix: str = "") -> None:
    """Raise ConfigError for the first field of the dataclass `settings` outside its range ("scenario.lanes must be
    between 1 and 10, got 0"; an unset optional one, None, is in range); a field that is itself a dataclass is
    checked with its name as the prefix."""
    for field in dataclasses.fields(settings):
        value, key = getattr(settings, field.name), f"{prefix}{field.name}"
        if dataclasses.is_dataclass(value):
            check_fields(value, f"{key}.")
        elif (bounds := bounds_of(field)) is not None and value is not None and not bounds.holds(value):
            finite = "" if math.isfinite(value) else "a finite number "
            raise ConfigError(f"{key} must be {finite}{bounds.describe()}, got {_number(value)}")


def given(source: str, default: Any = dataclasses.MISSING, **field_options: Any) -> Any:
    """A field its command fills from `source` (an option, "--seed", or another setting, "network.hidden") rather
    than a setting of its own section: `replace_settings` refuses it, naming `source`."""
    return dataclasses.field(default=default, metadata={"given_by": source}, **field_options)


def given_by(field: dataclasses.Field[Any]) -> str | None:
    """Where a `given` field's value comes from; None for a setting."""
    return field.metadata.get("given_by")


def replace_settings(name: str, section: Any, values: Mapping[str, Any]) -> Any:
    """A copy of the settings dataclass `section` (named `name`, e.g. "rail") with `values` replaced, a field that is
    itself a dataclass by a nested table ("rail.noise"). Unknown keys, `given` fields, values of the wrong type and
    values the dataclass's own checks refuse raise a one-sentence ConfigError naming the setting (ranges of `bounded`
    fields are `check_fields`' job)."""
    fields = {f.name: f for f in dataclasses.fields(section)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ConfigError(f"unknown config key(s) {[f'{name}.{key}' for key in unknown]}")
    for key in values:
        if (source := given_by(fields[key])) is not None:
            raise ConfigError(f"{name}.{key} is not set here: it comes from {source}")
    hints = typing.get_type_hints(type(section))
    coerced = {key: _coerced(f"{name}.{key}", value, hints[key], getattr(section, key))
               for key, value in values.items()}
    for key, value in coerced.items():  # a bounded field's range says it finite (`check_fields`)
        if isinstance(value, float) and not math.isfinite(value) and bounds_of(fields[key]) is None:
            raise ConfigError(f"{name}.{key} must be a finite number, got {value}")
    try:
        return dataclasses.replace(section, **coerced)
    except ConfigError:
        raise
    except ValueError as error:  # the dataclass's own checks, e.g. rail.top above rail.directions
        raise ConfigError(str(error)) from error


def _coerced(key: str, value: Any, hint: Any, current: Any) -> Any:
    """`value` as the setting `key` of declared type `hint` (whose value now is `current`) takes it."""
    if dataclasses.is_dataclass(current):
        if not isinstance(value, Mapping):
            raise ConfigError(f"{key} is a table of settings, got {value!r}")
        return replace_settings(key, current, value)
    kinds = [kind for kind in typing.get_args(hint) if kind is not type(None)] if _is_union(hint) else [hint]
    if typing.get_origin(kinds[0]) is tuple:
        if not isinstance(value, list | tuple) or not all(isinstance(item, str) for item in value):
            raise ConfigError(f"{key} must be a list of strings, got {value!r}")
        return tuple(value)
    return coerce(key, value, kinds[0])


def _is_union(hint: Any) -> bool:
    return typing.get_origin(hint) in (typing.Union, types.UnionType)


def coerce(key: str, value: Any, kind: type) -> Any:
    """`value` as the setting `key` of type `kind` (bool, float, int or str) takes it: an integer for a float becomes
    a float; anything else of the wrong type raises ConfigError."""
    if kind is bool and isinstance(value, bool):
        return value
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    if kind is int and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind is str and isinstance(value, str):
        return value
    names = {bool: "true or false", float: "a number", int: "an integer", str: "a string"}
    raise ConfigError(f"{key} must be {names[kind]}, got {value!r}")


def _number(value: float) -> str:
    """A bound or a value as a user writes it: 70, 0.1, 2147483647, 1e+12, nan."""
    if isinstance(value, int) or (math.isfinite(value) and float(value).is_integer() and abs(value) < 1e9):
        return str(int(value))
    return f"{value:g}"
