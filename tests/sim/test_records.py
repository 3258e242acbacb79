"""`quick_init`: a frozen dataclass made in one store is the dataclass its generated `__init__` makes."""

from __future__ import annotations

import copy
import dataclasses
import inspect
import pickle
from dataclasses import dataclass, field

import pytest

from sumo_rail.sim.actions import Command
from sumo_rail.sim.records import quick_init
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.traffic import LaneGap, LaneGaps, TrafficView
from sumo_rail.sim.vehicles import EgoState, Neighbours, PeriodReport


def frozen_record(name: str) -> type:
    """A frozen dataclass `name` with a field of each kind: plain, with a default, with a default factory, and left
    out of repr and comparison; made twice from this one definition, so the two differ only by quick_init."""
    fields = [("a", float), ("b", int, 3), ("c", dict, field(default_factory=dict)),
              ("d", str, field(default="", repr=False, compare=False))]
    return dataclasses.make_dataclass(name, fields, frozen=True, namespace={"__module__": __name__})


Generated = frozen_record("Generated")
Quick = quick_init(frozen_record("Quick"))


@pytest.mark.parametrize(("args", "kwargs"), [((1.5,), {}), ((1.5, 4), {}), ((1.5,), {"c": {"x": 1}, "d": "y"}),
                                              ((), {"a": 2.0, "b": 5, "c": {}, "d": "z"})])
def test_a_quick_record_holds_what_the_generated_init_stores(args, kwargs):
    generated, quick = Generated(*args, **kwargs), Quick(*args, **kwargs)
    assert vars(quick) == vars(generated)
    assert repr(quick) == repr(generated).replace("Generated", "Quick")
    assert dataclasses.astuple(quick) == dataclasses.astuple(generated)
    assert quick == Quick(*args, **kwargs) and quick != Quick(-1.0)
    assert pickle.loads(pickle.dumps(quick)) == quick and copy.deepcopy(quick) == quick
    assert dataclasses.replace(quick, b=7) == Quick(quick.a, 7, quick.c, quick.d)
    with pytest.raises(dataclasses.FrozenInstanceError):
        quick.a = 0.0  # type: ignore[misc]


def test_a_default_factory_makes_a_new_value_for_each_record():
    assert Quick(1.0).c == {} and Quick(1.0).c is not Quick(1.0).c


def test_quick_init_keeps_the_parameters_and_refuses_what_it_would_skip():
    assert list(inspect.signature(Quick).parameters) == ["a", "b", "c", "d"]
    with pytest.raises(TypeError):
        Quick()  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        quick_init(dataclass(type("Mutable", (), {"__annotations__": {"a": "float"}})))
    with pytest.raises(TypeError):
        quick_init(dataclass(frozen=True)(type("Posted", (), {"__annotations__": {"a": "float"},
                                                              "__post_init__": lambda self: None})))


@pytest.mark.parametrize("cls", [EgoState, Neighbours, PeriodReport, RouteView, TrafficView, Command, LaneGaps,
                                 LaneGap])
def test_the_per_decision_records_take_their_fields_in_order(cls):
    assert list(inspect.signature(cls).parameters) == [f.name for f in dataclasses.fields(cls)]
    values = [object() for _ in dataclasses.fields(cls)]
    assert [getattr(cls(*values), f.name) for f in dataclasses.fields(cls)] == values
