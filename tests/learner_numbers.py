"""The learner sections' numbers, found by walking every section (importable: tests/ is on the path)."""

import dataclasses
import typing

from sumo_rail.bounds import given_by
from sumo_rail.learning.settings import SECTIONS, default_section


def learner_numbers() -> list[tuple[str, dataclasses.Field, type]]:
    """(dotted key, field, int or float) for every number a user sets in a learner section, nested tables and
    optional (None by default) ones too; fields a command fills itself (`given`) are no settings."""
    found = []

    def walk(key: str, section) -> None:
        hints = typing.get_type_hints(type(section))
        for field in dataclasses.fields(section):
            value = getattr(section, field.name)
            if given_by(field) is not None:
                continue
            if dataclasses.is_dataclass(value):
                walk(f"{key}.{field.name}", value)
                continue
            kinds = [kind for kind in typing.get_args(hints[field.name]) or (hints[field.name],)
                     if kind is not type(None)]
            if kinds[0] in (int, float):
                found.append((f"{key}.{field.name}", field, kinds[0]))
    for name in SECTIONS:
        walk(name, default_section(name))
    return found
