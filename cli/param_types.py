"""Click parameter types of the commands' options: `FiniteFloat`, the type of every float option."""

from __future__ import annotations

import math
from typing import Any

import click


class FiniteFloat(click.FloatRange):
    """A float option's type: a finite number within the optional range of click.FloatRange (min, max, min_open,
    max_open). NaN and +-inf are usage errors (exit 2) naming the option; FloatRange alone lets NaN through every
    range, as every comparison with NaN is false."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = click.FLOAT.convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value} is not a finite number.", param, ctx)
        return super().convert(number, param, ctx)
