"""Frozen dataclasses that are cheap to make: the per-decision records (an ego's state, its neighbours, its route view,
a period's report, the traffic view) are made several times a decision.

A frozen dataclass's generated `__init__` stores each field with its own `object.__setattr__` call (about 2 k
instructions a field in CPython 3.11); `quick_init` gives the class an `__init__` with the same parameters and defaults
that stores the instance's dict in one call. Instances are the same in every other way (fields, equality, hash, repr,
immutability, `dataclasses.replace`, pickling).
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

T = TypeVar("T")
_FACTORY = object()
"""Default of a parameter whose field has a default factory: the factory is called when it is not given."""


def quick_init(cls: type[T]) -> type[T]:
    """Replace the generated `__init__` of frozen dataclass `cls` (without `__post_init__`) by one that stores every
    field at once."""
    if not (dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen):  # type: ignore[attr-defined]
        raise TypeError(f"{cls.__name__} is not a frozen dataclass")
    if hasattr(cls, "__post_init__"):
        raise TypeError(f"{cls.__name__} has a __post_init__, which quick_init would skip")
    fields = dataclasses.fields(cls)
    if not all(field.init for field in fields):
        raise TypeError(f"{cls.__name__} has a field outside __init__, which quick_init does not handle")
    namespace: dict[str, Any] = {"_set": object.__setattr__, "_FACTORY": _FACTORY}
    parameters, values = [], []
    for field in fields:
        if field.default is not dataclasses.MISSING:
            namespace[f"_default_{field.name}"] = field.default
            parameters.append(f"{field.name}=_default_{field.name}")
            values.append(field.name)
        elif field.default_factory is not dataclasses.MISSING:
            namespace[f"_factory_{field.name}"] = field.default_factory
            parameters.append(f"{field.name}=_FACTORY")
            values.append(f"_factory_{field.name}() if {field.name} is _FACTORY else {field.name}")
        else:
            parameters.append(field.name)
            values.append(field.name)
    stored = ", ".join(f"{field.name!r}: {value}" for field, value in zip(fields, values, strict=True))
    source = f"def __init__(self, {', '.join(parameters)}):\n    _set(self, '__dict__', {{{stored}}})\n"
    exec(source, namespace)  # code built from the class's own field names, as dataclasses builds its own
    init = namespace["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__doc__ = cls.__init__.__doc__
    cls.__init__ = init  # type: ignore[method-assign]  # the point of quick_init
    return cls
