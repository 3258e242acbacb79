import dataclasses

import numpy as np
import pytest
from scenes import EGO_FRONT, view

from sumo_rail.drivers.expert import STYLES, Expert, Seeker, make_expert
from sumo_rail.runners.rollout import ExpertDriver, run_episode
from sumo_rail.sim.actions import Action
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.road import RouteView
from sumo_rail.sim.traffic import lane_gap_list, lane_gaps


def sporty() -> Expert:
    return make_expert("sporty", speed_step_mps=2.0)


def test_lane_gaps_pick_nearest_leader_and_follower_bumper_to_bumper():
    traffic = view([(1, 1050.0, 4.5, 20.0), (1, 1100.0, 4.5, 30.0), (1, 970.0, 12.0, 22.0), (1, 900.0, 4.5, 35.0),
                    (2, 1002.0, 4.5, 30.0)])
    gaps = lane_gaps(traffic, 1)
    assert gaps.front_gap_m == pytest.approx(1050.0 - 4.5 - EGO_FRONT) and gaps.front_speed_mps == 20.0
    assert gaps.rear_gap_m == pytest.approx(EGO_FRONT - 4.5 - 970.0) and gaps.rear_speed_mps == 22.0
    assert not gaps.alongside
    assert lane_gaps(traffic, 2).alongside
    empty = lane_gaps(traffic, 3)
    assert np.isinf(empty.front_gap_m) and np.isinf(empty.rear_gap_m) and not empty.alongside


def test_overtakes_a_slow_leader_when_the_left_lane_is_free():
    traffic = view([(1, 1040.0, 12.0, 22.0)], speed=24.0, set_point=33.33)
    assert sporty().decide(traffic) is Action.LANE_LEFT


@pytest.mark.parametrize("left_lane_car", [
    (1, 1001.0, 4.5, 24.0),   # alongside
    (1, 985.0, 4.5, 34.0),    # fast follower close behind
    (1, 1012.0, 4.5, 20.0),   # slower leader just ahead
])
def test_never_asks_for_an_unsafe_overtake(left_lane_car):
    traffic = view([(0, 1040.0, 12.0, 22.0), left_lane_car], lane=0, speed=24.0, set_point=33.33)
    assert sporty().decide(traffic) is Action.KEEP
    assert sporty().decide(view([(0, 1040.0, 12.0, 22.0)], lane=0, speed=24.0, set_point=33.33)) is Action.LANE_LEFT


def test_no_left_change_from_the_leftmost_lane_and_none_while_changing():
    slow_leader = [(4, 1040.0, 12.0, 22.0)]
    assert sporty().decide(view(slow_leader, lane=4, speed=24.0, set_point=33.33)) is not Action.LANE_LEFT
    changing = view([(1, 1040.0, 12.0, 22.0)], speed=24.0, set_point=30.0, lateral=0.8)
    assert sporty().decide(changing) is Action.ACCELERATE


def test_returns_right_when_the_right_lane_is_free_and_not_when_it_is_slow():
    expert = make_expert("calm", speed_step_mps=2.0)
    desired = STYLES["calm"].desired_speed_mps
    assert expert.decide(view(lane=2, speed=desired, set_point=desired)) is Action.LANE_RIGHT
    slow_right = view([(1, 1060.0, 12.0, 22.0)], lane=2, speed=desired, set_point=desired)
    assert expert.decide(slow_right) is Action.KEEP


def test_speed_moves_toward_the_desired_speed():
    expert = make_expert("calm", speed_step_mps=2.0)
    desired = STYLES["calm"].desired_speed_mps
    assert expert.decide(view(lane=0, set_point=desired - 4)) is Action.ACCELERATE
    assert expert.decide(view(lane=0, set_point=desired + 4)) is Action.DECELERATE
    assert expert.decide(view(lane=0, set_point=desired + 0.5)) is Action.KEEP


def test_unknown_style_names_the_known_ones():
    with pytest.raises(ValueError, match="calm"):
        make_expert("reckless", 2.0)


def test_expert_episodes_are_deterministic_collision_free_and_styles_differ(small_config):
    env = HighwayEnv(small_config)
    try:
        runs = {style: [run_episode(env, ExpertDriver(style).create(small_config, seed), seed, record=True)
                        for seed in (11, 14, 17)] for style in ("calm", "sporty")}
        again = run_episode(env, ExpertDriver("calm").create(small_config, 11), 11, record=True)
    finally:
        env.close()
    assert np.array_equal(again.steps["action"], runs["calm"][0].steps["action"])
    assert again.metrics == runs["calm"][0].metrics
    for results in runs.values():
        assert all(result.metrics["collisions"] == 0 for result in results)

    def mean_speed(style):
        return np.mean([r.metrics["average_speed_kmh"] for r in runs[style]])

    assert mean_speed("sporty") > mean_speed("calm") + 3.0


def test_expert_limited_to_its_view_range_ignores_a_far_slow_leader():
    slow_leader_far = view([(1, 1110.0, 12.0, 22.0)], speed=33.0, set_point=33.33)  # its front 110 m ahead
    assert make_expert("sporty", 2.0).decide(slow_leader_far) is Action.LANE_LEFT
    assert make_expert("sporty", 2.0, view_range_m=115.0).decide(slow_leader_far) is Action.LANE_LEFT
    assert make_expert("sporty", 2.0, view_range_m=100.0).decide(slow_leader_far) is not Action.LANE_LEFT


def on_a_closing_lane(traffic, lane_end_m):
    """`traffic` with the ego's lane (0 of three) ending `lane_end_m` ahead, its route going on in lanes 1 and 2."""
    route = RouteView(lowest_lane=0, highest_lane=2, lane_end_m=(lane_end_m, np.inf, np.inf), merge_ahead_m=np.inf,
                      diverge_ahead_m=np.inf, route_left_m=np.inf)
    return dataclasses.replace(traffic, ego=dataclasses.replace(traffic.ego, route=route), lanes=3)


def test_lane_gaps_give_the_speed_of_the_vehicle_alongside_nearest_the_ego():
    traffic = view([(2, 1002.0, 4.5, 30.0), (2, 1006.0, 12.0, 22.0)])
    assert lane_gaps(traffic, 2).alongside_speed_mps == 30.0
    assert np.isinf(lane_gaps(traffic, 1).alongside_speed_mps)


@pytest.mark.parametrize("fast_car", [(1, 1001.0, 4.5, 32.0),   # alongside
                                      (1, 990.0, 4.5, 32.0)])   # close behind
def test_lets_a_car_faster_than_it_would_drive_pass_before_merging(fast_car):
    """Outrunning a car above its desired speed (30.5 m/s) would never open a gap: it drops behind instead."""
    expert = make_expert("normal", speed_step_mps=2.0)
    traffic = on_a_closing_lane(view([fast_car], lane=0, speed=30.0, set_point=31.33), lane_end_m=400.0)
    assert expert.decide(traffic) is Action.DECELERATE


def test_passes_a_slower_car_alongside_into_an_open_lane_up_to_its_desired_speed_plus_the_margin():
    expert = make_expert("normal", speed_step_mps=2.0)
    traffic = on_a_closing_lane(view([(1, 1001.0, 4.5, 20.0)], lane=0, speed=20.0, set_point=21.33), 400.0)
    assert expert.decide(traffic) is Action.ACCELERATE
    done = on_a_closing_lane(view([(1, 1001.0, 4.5, 20.0)], lane=0, speed=30.0, set_point=33.33), 400.0)
    assert expert.decide(done) is Action.KEEP, "30.5 + the 3 m/s margin reached"


def test_in_the_last_metres_of_its_lane_it_counts_on_harder_braking_behind_but_never_on_a_crash():
    expert = make_expert("normal", speed_step_mps=2.0)
    ego_rear = EGO_FRONT - 4.5
    closing_10 = [(1, EGO_FRONT + 40.0, 4.5, 25.0), (1, ego_rear - 20.0, 4.5, 20.0)]  # 20 m behind, 10 m/s faster
    last_metres = on_a_closing_lane(view(closing_10, lane=0, speed=10.0, set_point=17.33), lane_end_m=40.0)
    assert expert.decide(last_metres) is Action.LANE_LEFT, "6 m + 10^2 / (2 * 4) = 18.5 m needed"
    earlier = on_a_closing_lane(view(closing_10, lane=0, speed=10.0, set_point=17.33), lane_end_m=100.0)
    assert expert.decide(earlier) is not Action.LANE_LEFT, "6 m + 10^2 / (2 * 3) = 22.7 m needed"
    closing_13 = [(1, EGO_FRONT + 40.0, 4.5, 25.0), (1, ego_rear - 16.0, 4.5, 23.6)]
    too_fast = on_a_closing_lane(view(closing_13, lane=0, speed=10.8, set_point=17.33), lane_end_m=20.0)
    assert expert.decide(too_fast) is not Action.LANE_LEFT, "a follower 12.8 m/s faster 16 m behind cannot stop"


def test_lane_gap_list_gives_every_gap_of_a_lane_from_the_rearmost():
    traffic = view([(0, 1050.0, 4.5, 20.0), (0, 970.0, 12.0, 22.0), (1, 1100.0, 4.5, 30.0)], lane=1)
    gaps = lane_gap_list(traffic, 0)
    assert [(g.behind_m, g.ahead_m) for g in gaps] == [(-np.inf, 970.0 - 12.0 - EGO_FRONT),
                                                      (970.0 - EGO_FRONT, 1050.0 - 4.5 - EGO_FRONT),
                                                      (1050.0 - EGO_FRONT, np.inf)]
    assert [g.ahead_speed_mps for g in gaps] == [22.0, 20.0, np.inf]
    assert len(lane_gap_list(traffic, 3)) == 1


def test_passes_a_slower_vehicle_alongside_as_fast_as_the_gap_ahead_of_it_allows():
    """Slowing to 24.8 + 3 m/s to pass a truck alongside left it alongside until SUMO braked the ego for its lane's
    end (a missed exit): it passes at the speed difference it can shed at 1 m/s^2 by the middle of the gap ahead
    (16.5 + 89.5 m) / 2 = 53 m away: 10.3 m/s), here up to its desired speed plus the margin."""
    expert = make_expert("normal", speed_step_mps=2.0)
    truck_alongside = [(1, EGO_FRONT + 6.0, 12.0, 24.8), (1, EGO_FRONT + 100.0, 4.5, 24.7)]
    traffic = on_a_closing_lane(view(truck_alongside, lane=0, speed=31.3, set_point=31.33), lane_end_m=200.0)
    assert expert.decide(traffic) is Action.ACCELERATE


def test_passes_a_vehicle_it_cannot_drop_behind_into_the_gap_ahead_of_it():
    """A car alongside at 17 m/s, below the 18.3 m/s it slows to when merging: dropping behind it never happens
    (on the ramp it stayed alongside for 150 m), passing it into the gap in front does."""
    expert = make_expert("normal", speed_step_mps=2.0)
    slow_car = [(1, EGO_FRONT + 2.0, 4.5, 17.0), (1, EGO_FRONT + 35.5, 4.5, 20.0), (1, EGO_FRONT - 40.0, 4.5, 17.0)]
    traffic = on_a_closing_lane(view(slow_car, lane=0, speed=18.0, set_point=18.0), lane_end_m=200.0)
    assert expert.decide(traffic) is Action.ACCELERATE


def test_drops_back_to_the_gap_behind_when_the_gaps_ahead_are_too_short_for_it():
    """Passing the car alongside would only reach gaps ahead too short for its time gaps (51 m at 25 m/s behind,
    36 m in front): the long gap behind the car 40 m back comes sooner."""
    expert = make_expert("normal", speed_step_mps=2.0)
    ego_rear = EGO_FRONT - 4.5
    cars = [(1, EGO_FRONT + 2.0, 4.5, 25.0), (1, EGO_FRONT + 60.0, 4.5, 25.0), (1, EGO_FRONT + 120.0, 4.5, 25.0),
            (1, EGO_FRONT + 210.0, 4.5, 25.0), (1, ego_rear - 40.0, 4.5, 25.0)]
    traffic = on_a_closing_lane(view(cars, lane=0, speed=25.0, set_point=25.33), lane_end_m=400.0)
    assert expert.decide(traffic) is Action.DECELERATE


def test_lines_up_with_a_zip_gap_when_no_gap_for_its_time_gaps_comes_before_the_zip_merge():
    """A dense lane at 25 m/s, a car every 30 m as far as it sees: no gap is long enough for its time gaps (85 m), and
    the road beyond the last car seen (105 m ahead) is 20 s away at +3 m/s while the zip merge begins in 8 s. Chasing
    it brought the ego to the zip merge 8 m/s faster than the lane, overshooting every gap (stopped at the lane's
    end): it keeps pace with the lane in the zip gap it is in instead."""
    expert = make_expert("normal", speed_step_mps=2.0)
    cars = [(1, EGO_FRONT + offset, 4.5, 25.0) for offset in (-75.0, -45.0, -15.0, 15.0, 45.0, 75.0, 105.0)]
    traffic = on_a_closing_lane(view(cars, lane=0, speed=25.0, set_point=25.33), lane_end_m=450.0)
    assert expert.decide(traffic) is Action.KEEP
    sooner = on_a_closing_lane(view(cars[3:5], lane=0, speed=25.0, set_point=25.33), lane_end_m=450.0)
    assert expert.decide(sooner) is Action.DECELERATE, "the road behind the two cars ahead is reached in 6 s"


def test_lines_up_with_a_zip_gap_only_for_the_last_change_the_route_demands():
    """Two lanes to cross before both end: settling into a zip gap of the first would leave both changes to the last
    250 m (missed exits from the leftmost lane): it seeks a gap for its time gaps there as before."""
    expert = make_expert("normal", speed_step_mps=2.0)
    cars = [(1, EGO_FRONT + offset, 4.5, 25.0) for offset in (-75.0, -45.0, -15.0, 15.0, 45.0, 75.0, 105.0)]
    traffic = view(cars, lane=0, speed=25.0, set_point=25.33)
    route = RouteView(lowest_lane=0, highest_lane=2, lane_end_m=(450.0, 450.0, np.inf), merge_ahead_m=np.inf,
                      diverge_ahead_m=np.inf, route_left_m=np.inf)
    two_to_cross = dataclasses.replace(traffic, ego=dataclasses.replace(traffic.ego, route=route), lanes=3)
    assert expert.decide(on_a_closing_lane(traffic, lane_end_m=450.0)) is Action.KEEP, "one to cross: lines up"
    assert expert.decide(two_to_cross) is not Action.KEEP


def test_zip_merges_a_few_metres_in_front_of_a_follower_no_faster_than_itself():
    """130 m before its lane's end, 3.1 m ahead of a car at 24 m/s while SUMO brakes it (27.3 m/s) for that end: its
    minimum gap (6 m) left it there, alongside again once slower, until it missed the exit (exit, validation 9000);
    in front of a follower no faster than itself it zip merges with SUMO's largest standstill gap, 3 m. A faster
    follower still gets its minimum gap."""
    expert = make_expert("normal", speed_step_mps=2.0)
    ego_rear = EGO_FRONT - 4.5
    slower = [(1, ego_rear - 3.1, 4.5, 24.0), (1, EGO_FRONT + 48.0, 4.5, 24.7)]
    traffic = on_a_closing_lane(view(slower, lane=0, speed=27.3, set_point=31.33), lane_end_m=130.0)
    assert expert.decide(traffic) is Action.LANE_LEFT
    faster = [(1, ego_rear - 3.1, 4.5, 27.5), (1, EGO_FRONT + 48.0, 4.5, 24.7)]
    assert expert.decide(on_a_closing_lane(view(faster, lane=0, speed=27.3, set_point=31.33), 130.0)) is not (
        Action.LANE_LEFT)
    earlier = on_a_closing_lane(view(slower, lane=0, speed=27.3, set_point=31.33), lane_end_m=300.0)
    assert expert.decide(earlier) is not Action.LANE_LEFT, "before the zip merge: its time gaps"


def test_drops_behind_a_vehicle_alongside_when_its_own_leader_keeps_it_at_that_vehicle_s_speed():
    """A truck alongside at 24.9 m/s, nearly passed, the gap ahead of it long, but its own leader 38 m ahead at 25 m/s:
    SUMO's ACC holds it within 0.5 m/s of that leader whatever its set-point, so it stayed alongside until it missed
    the exit (exit, validation 9000). It drops behind the truck instead; with its own lane clear it passes."""
    expert = make_expert("normal", speed_step_mps=2.0)
    ego_rear = EGO_FRONT - 4.5
    cars = [(1, EGO_FRONT + 2.0, 12.0, 24.9), (1, EGO_FRONT + 80.0, 4.5, 25.0), (1, ego_rear - 45.0, 4.5, 24.6)]
    leader = [(0, EGO_FRONT + 42.9, 4.5, 25.0)]
    traffic = on_a_closing_lane(view(cars + leader, lane=0, speed=25.4, set_point=27.33), lane_end_m=250.0)
    assert expert.decide(traffic) is Action.DECELERATE
    clear = on_a_closing_lane(view(cars, lane=0, speed=25.4, set_point=27.33), lane_end_m=250.0)
    assert expert.decide(clear) is Action.ACCELERATE


def test_a_change_its_route_demands_counts_a_slower_follower_s_shorter_braking_distance():
    """40 m ahead of a car at 31 m/s, itself at 33 m/s, 400 m before its lane's end: its 1.5 s time gap asks 52.5 m,
    which it built up at 2 m/s only after 250 m (exit, validation 9000: then too late for the next change). Both
    braking at 4.5 m/s^2 that car stops 14.2 m shorter: 38.3 m suffice. A car as fast as itself still needs 55.5 m."""
    expert = make_expert("normal", speed_step_mps=2.0)
    ego_rear = EGO_FRONT - 4.5
    slower = on_a_closing_lane(view([(1, ego_rear - 40.0, 4.5, 31.0)], lane=0, speed=33.0, set_point=33.33), 400.0)
    assert expert.decide(slower) is Action.LANE_LEFT
    as_fast = on_a_closing_lane(view([(1, ego_rear - 40.0, 4.5, 33.0)], lane=0, speed=33.0, set_point=33.33), 400.0)
    assert expert.decide(as_fast) is not Action.LANE_LEFT


def test_passes_a_vehicle_only_when_it_draws_ahead_before_sumo_brakes_it_for_its_lane_s_end():
    """184 m before its lane's end at 27.1 m/s, a car at 22.9 m/s 8.5 m ahead in the lane it needs: SUMO brakes it at
    3 m/s^2 from about 130 m on (28.1^2 / 6, at the 28.1 m/s its ACC allows behind its own leader), so it gains 14 m
    on that car before it is slower, not the 16 m to merge 3 m ahead of it (exit, validation 9000: it passed at +5 m/s
    until it was braked alongside, and missed the exit). It drops behind the car instead; 400 m before the end it
    has the room to pass (54 m)."""
    expert = make_expert("normal", speed_step_mps=2.0)
    cars = [(1, EGO_FRONT + 8.5, 4.5, 22.9), (1, EGO_FRONT - 35.2, 4.5, 24.0), (1, EGO_FRONT + 37.7, 4.5, 23.5),
            (0, EGO_FRONT + 99.7, 4.5, 24.8)]
    late = on_a_closing_lane(view(cars, lane=0, speed=27.1, set_point=27.33), lane_end_m=184.0)
    assert expert.decide(late) is Action.DECELERATE
    seeker = Seeker(speed_mps=27.1, length_m=4.5, own=lane_gaps(late, 0), lane_end_m=184.0)
    assert seeker.can_gain(13.5, 22.9, 28.1) and not seeker.can_gain(14.5, 22.9, 28.1)
    assert Seeker(27.1, 4.5, lane_gaps(late, 0), lane_end_m=400.0).can_gain(16.0, 22.9, 28.1)
