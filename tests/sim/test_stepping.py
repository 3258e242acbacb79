"""A decision period's steps (`Stepping.advance_egos`) on a stand-in for SUMO's calls, without SUMO."""

from __future__ import annotations

from types import SimpleNamespace

import libsumo
import pytest
import traci.constants

from sumo_rail.sim.stepping import Stepping
from sumo_rail.sim.sumo_api import INVALID_VALUE
from sumo_rail.sim.traffic_source import GeneratedTraffic


def stepping(readings: dict[str, list[float]], traffic: object = GeneratedTraffic()) -> Stepping:
    """A `Stepping` whose SUMO answers each vehicle's acceleration at step k with `readings[vehicle][k]`, its traffic
    `traffic`."""
    steps = SimpleNamespace(done=0)

    def step() -> None:
        steps.done += 1

    stepper = Stepping()
    stepper._api = SimpleNamespace(simulation=SimpleNamespace(getTime=lambda: steps.done * 0.1))
    stepper._client = SimpleNamespace(TraCIException=RuntimeError)
    stepper._calls = (step, lambda: 0, lambda vehicle: readings[vehicle][steps.done - 1])  # type: ignore[assignment]
    stepper.traffic = traffic  # type: ignore[assignment]
    return stepper


def test_sumos_invalid_value_is_the_constant_of_both_transports():
    assert INVALID_VALUE == libsumo.INVALID_DOUBLE_VALUE == traci.constants.INVALID_DOUBLE_VALUE


def test_a_vehicle_waiting_to_be_inserted_has_no_acceleration_yet():
    """SUMO answers INVALID_VALUE (-1073741824) for the acceleration of a vehicle still waiting to be inserted: it is
    missing, not a braking of 1e9 m/s^2, for an ego and for a watched vehicle alike."""
    report, = stepping({"ego": [INVALID_VALUE, INVALID_VALUE, -0.5, 1.0],
                        "follower": [INVALID_VALUE, -2.0, -1.0, INVALID_VALUE]}).advance_egos(4, ["ego"], ["follower"])
    assert report.accelerations_mps2 == (-0.5, 1.0) and report.min_acceleration_mps2 == -0.5
    assert report.watched_min_acceleration_mps2 == {"follower": -2.0}
    waiting, = stepping({"ego": [INVALID_VALUE] * 3, "follower": [INVALID_VALUE] * 3}).advance_egos(3, ["ego"],
                                                                                                  ["follower"])
    assert waiting.accelerations_mps2 == () and waiting.min_acceleration_mps2 == pytest.approx(0.0)
    assert waiting.watched_min_acceleration_mps2 == {} and not waiting.ego_collided


def test_an_ego_the_traffic_saw_collide_collided():
    """SUMO still answers for an ego that ran into a replayed vehicle in the period's last step (it leaves at the
    next): the period's report says it collided, from the traffic's record; the other egos' reports stay as they are."""
    readings = {"ego": [0.0] * 5, "other": [0.0] * 5}
    assert not any(report.ego_collided for report in stepping(readings).advance_egos(5, ["ego", "other"]))
    ego, other = stepping(readings, SimpleNamespace(collided=("ego",))).advance_egos(5, ["ego", "other"])
    assert ego.ego_collided and not ego.ego_left_network and not other.ego_collided


def test_an_ego_gone_after_a_collision_the_traffic_saw_collided():
    """SUMO may drop an ego that ran into a replayed vehicle one step after naming the collision; the traffic's own
    record of the ego's collisions says why it is gone."""
    assert stepping({}, SimpleNamespace(collided=("ego",)))._why_gone("ego") == (True, False)
