"""Click parameter types of the commands' options: `FiniteFloat`, the type of every float option, and `setting_range`,
the type of an option that takes a setting's values."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import click

from sumo_rail.bounds import bounds_of


class FiniteFloat(click.FloatRange):
    """A float option's type: a finite number within the optional range of click.FloatRange (min, max, min_open,
    max_open). NaN and +-inf are usage errors (exit 2) naming the option; FloatRange alone lets NaN through every
    range, as every comparison with NaN is false."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number.", param, ctx)
        return super().convert(number, param, ctx)


def setting_range(settings: type, name: str) -> click.ParamType:
    """The type of an option whose values are those of the `bounded` field `name` of the settings dataclass
    `settings` (e.g. SUMO's seed, `ScenarioConfig.traffic_seed`): its range, declared once with the field."""
    field = next(field for field in dataclasses.fields(settings) if field.name == name)
    bounds = bounds_of(field)
    if bounds is None:
        raise TypeError(f"{settings.__name__}.{name} has no range")
    if bounds.integer:
        return click.IntRange(int(bounds.low), int(bounds.high), min_open=bounds.low_open, max_open=bounds.high_open)
    return FiniteFloat(bounds.low, bounds.high, min_open=bounds.low_open, max_open=bounds.high_open)


class RoadList(click.ParamType):
    """--roads' type: road names (scenario kinds) separated by commas, blanks around them dropped, as a tuple; a list
    that names no road ("", ",") is a usage error (exit 2) naming the option, as leaving --roads out is the way to
    keep the configured road."""

    name = "roads"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, tuple):
            return value
        roads = tuple(road.strip() for road in str(value).split(",") if road.strip())
        if not roads:
            self.fail(f"{value!r} names no road; give scenario kinds separated by commas, e.g. straight,merge, or "
                      f"leave the option out for the configured road", param, ctx)
        return roads
