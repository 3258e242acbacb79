"""SUMO vehicle types given as plain data (a recording's, from a user's route or additional file): read from the
file's `<vType>` elements, checked by SUMO itself, and written back into the routes file of a scene's simulation.

A definition is a vType's attributes (its id left out) with its children kept in it: a `<carFollowing-MODEL .../>`
child (SUMO's older way of giving the car-following model) as `carFollowModel` MODEL and the child's attributes (the
same type to SUMO), each `<param key=... value=...>` child as the key `PARAM_PREFIX` + key (`vtype_element` writes
it back as a `<param>` child).
"""

from __future__ import annotations

import math
import tempfile
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping
from pathlib import Path

from sumo_rail.config import ConfigError
from sumo_rail.sim.user_network import sumo_load_errors

PARAM_PREFIX = "param:"
"""A definition's key of a `<param>` child: this prefix and the param's key."""
_CAR_FOLLOWING = "carFollowing-"


def read_vtypes(root: ElementTree.Element) -> dict[str, dict[str, str]]:
    """The vTypes under `root` (a route or additional file's root): id -> definition (module docstring); ConfigError
    in one sentence naming the type and what is wrong when one has no id, is defined twice, holds a number that is
    not finite or a child SUMO's vType does not take."""
    found: dict[str, dict[str, str]] = {}
    for vtype in root.iter("vType"):
        type_id = vtype.get("id", "")
        if not type_id:
            raise ConfigError(f"a vType without an id (attributes {dict(vtype.attrib)})")
        if type_id in found:
            raise ConfigError(f"vType {type_id!r} is defined twice")
        definition = {key: value for key, value in vtype.attrib.items() if key != "id"}
        for child in vtype:
            if child.tag == "param" and child.get("key"):
                definition[PARAM_PREFIX + str(child.get("key"))] = child.get("value", "")
            elif child.tag.startswith(_CAR_FOLLOWING):
                model = child.tag.removeprefix(_CAR_FOLLOWING)
                if definition.get("carFollowModel", model) != model:
                    raise ConfigError(f"vType {type_id!r} names carFollowModel {definition['carFollowModel']!r} "
                                      f"and has a <{child.tag}> child")
                definition |= {"carFollowModel": model, **child.attrib}
            else:
                raise ConfigError(f"vType {type_id!r} has a <{child.tag}> child (a vType takes <param key=... "
                                  f"value=...> and <carFollowing-MODEL> children)")
        for key, value in definition.items():
            if not key.startswith(PARAM_PREFIX) and _not_finite(value):
                raise ConfigError(f"vType {type_id!r} attribute {key} is {value!r}, not a finite number")
        found[type_id] = definition
    return found


def _not_finite(value: str) -> bool:
    """`value` reads as a number but not a finite one (nan, inf)."""
    try:
        return not math.isfinite(float(value))
    except ValueError:
        return False


def vtype_element(parent: ElementTree.Element, type_id: str, definition: Mapping[str, str]) -> ElementTree.Element:
    """The vType `type_id` of `definition` (module docstring) appended to `parent`."""
    element = ElementTree.SubElement(parent, "vType", attrib={
        **{key: value for key, value in definition.items() if not key.startswith(PARAM_PREFIX)}, "id": type_id})
    for key, value in definition.items():
        if key.startswith(PARAM_PREFIX):
            ElementTree.SubElement(element, "param", key=key.removeprefix(PARAM_PREFIX), value=value)
    return element


def check_vtypes(net_file: Path, definitions: Mapping[str, Mapping[str, str]]) -> None:
    """ConfigError naming the first of `definitions` SUMO refuses on `net_file` (an unknown model or vehicle class, an
    attribute it does not know or cannot read, a size out of range) with SUMO's reason: each is loaded as written
    into a scene's routes (`vtype_element`), then validated against SUMO's schema."""
    with tempfile.TemporaryDirectory() as folder:
        def refused(types: Mapping[str, Mapping[str, str]], validate: bool) -> list[str]:
            root = ElementTree.Element("routes")
            for type_id, definition in types.items():
                vtype_element(root, type_id, definition)
            routes = Path(folder) / "vtypes.rou.xml"
            routes.write_bytes(ElementTree.tostring(root))
            return sumo_load_errors(net_file, [routes], validate)

        for validate in (False, True):  # SUMO's own reasons first; its schema's name less (a value, not its attribute)
            if refused(definitions, validate):
                for type_id, definition in definitions.items():  # which one: SUMO does not always say
                    errors = refused({type_id: definition}, validate)
                    if errors:
                        raise ConfigError(f"SUMO refuses vType {type_id!r}: {errors[0].rstrip('.')}")
