"""sumo-gui's pace: PacedApi spaces SUMO steps by the --gui-delay, without a display or SUMO."""

from types import SimpleNamespace

from sumo_rail.sim.gui import PacedApi


def paced(step_wall_s: float):
    now = [0.0]
    sleeps: list[float] = []
    steps: list[tuple] = []

    def sleep(seconds: float) -> None:
        sleeps.append(seconds)
        now[0] += seconds

    api = SimpleNamespace(simulationStep=lambda *args: steps.append(args), vehicle="the vehicle domain")
    return PacedApi(api, step_wall_s, clock=lambda: now[0], sleep=sleep), now, sleeps, steps


def test_steps_start_one_delay_apart_counting_the_time_already_spent():
    api, now, sleeps, steps = paced(0.1)
    api.simulationStep()
    now[0] += 0.03  # the client worked 30 ms between two steps
    api.simulationStep()
    now[0] += 0.25  # and then longer than the delay: no wait
    api.simulationStep(12.0)
    assert len(sleeps) == 1 and abs(sleeps[0] - 0.07) < 1e-9
    assert steps == [(), (), (12.0,)]
    assert api.vehicle == "the vehicle domain"  # everything else is traci's own


def test_no_delay_never_sleeps():
    api, _, sleeps, steps = paced(0.0)
    for _ in range(5):
        api.simulationStep()
    assert sleeps == [] and len(steps) == 5
