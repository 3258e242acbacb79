"""A decision period's steps (`Stepping.advance_egos`) on a stand-in for SUMO's calls, without SUMO."""

from __future__ import annotations

from types import SimpleNamespace

import libsumo
import pytest
import traci.constants

from sumo_rail.sim.stepping import Stepping
from sumo_rail.sim.sumo_api import INVALID_VALUE


def stepping(readings: dict[str, list[float]]) -> Stepping:
    """A `Stepping` whose SUMO answers each vehicle's acceleration at step k with `readings[vehicle][k]`."""
    steps = SimpleNamespace(done=0)

    def step() -> None:
        steps.done += 1

    stepper = Stepping()
    stepper._api = SimpleNamespace(simulation=SimpleNamespace(getTime=lambda: steps.done * 0.1))
    stepper._client = SimpleNamespace(TraCIException=RuntimeError)
    stepper._calls = (step, lambda: 0, lambda vehicle: readings[vehicle][steps.done - 1])  # type: ignore[assignment]
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
