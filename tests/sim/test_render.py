"""The bird's-eye renderer: pure drawing tests on a synthetic road, then the env's rgb_array mode and video."""

import gymnasium
import numpy as np
import pytest

import sumo_rail
from sumo_rail.sim.env import HighwayEnv
from sumo_rail.sim.render import EGO, HIT, TYPE_COLOURS, FrameRenderer, FrameText
from sumo_rail.sim.simulation import EgoState, Neighbours

LANE_WIDTH = 3.2
LANES = 3


def straight_road(length_m: float = 1000.0) -> np.ndarray:
    """Right edge at y = -1.6, left edge at y = 3 * 3.2 - 1.6, along +x: segments (S, 2, 2)."""
    xs = np.linspace(0.0, length_m, 11)
    right = np.stack([xs, np.full_like(xs, -LANE_WIDTH / 2)], axis=1)
    left = np.stack([xs, np.full_like(xs, LANES * LANE_WIDTH - LANE_WIDTH / 2)], axis=1)
    segments = lambda points: np.stack([points[:-1], points[1:]], axis=1)  # noqa: E731
    return np.concatenate([segments(right), segments(left)])


def ego_in_lane(lane: int, front_x: float = 500.0) -> EgoState:
    return EgoState(front_x, lane * LANE_WIDTH, 0.0, 25.0, lane, front_x, 0.0, 4.5, 1.8)


def neighbours(rows: list[tuple[float, float, float]]) -> Neighbours:
    """(front x, y, length) of vehicles heading along +x."""
    array = np.array(rows, dtype=np.float64).reshape(len(rows), 3)
    count = len(rows)
    return Neighbours(tuple(f"v{k}" for k in range(count)), array[:, :2], np.zeros(count), np.full(count, 20.0),
                      array[:, 0], array[:, 2], np.full(count, 2.5), np.zeros(count, dtype=np.int64))


TEXT = FrameText(12.5, 25.0, 27.0, 1, LANES, "KEEP", 3)


def pixel(renderer: FrameRenderer, frame: np.ndarray, xy: tuple[float, float], ego: EgoState) -> tuple[int, ...]:
    ego_along = ego.front_x - ego.length_m / 2
    x, y = renderer.to_pixels(np.array(xy), ego_along)
    return tuple(int(v) for v in frame[round(y), round(x)])


def test_frame_draws_the_ego_in_red_at_the_centre_and_a_truck_in_its_colour_where_it_is():
    renderer = FrameRenderer(straight_road(), LANES)
    ego = ego_in_lane(1)
    truck_front = (540.0, 2 * LANE_WIDTH)  # 12 m truck, lane 2, its centre 34 m ahead of the ego's centre
    frame = renderer.draw(ego, neighbours([(*truck_front, 12.0)]), ["truck"], np.full(24, 100.0), 100.0, TEXT)
    assert frame.shape == (renderer.height, renderer.width, 3) and frame.dtype == np.uint8
    assert frame.shape[0] % 16 == 0 and frame.shape[1] % 16 == 0
    assert pixel(renderer, frame, (ego.front_x - 2.25, ego.lateral_offset_m + LANE_WIDTH), ego) == EGO
    assert pixel(renderer, frame, (truck_front[0] - 6.0, truck_front[1]), ego) == TYPE_COLOURS["truck"]
    # nothing where the truck is not
    assert pixel(renderer, frame, (truck_front[0] + 10.0, truck_front[1]), ego) != TYPE_COLOURS["truck"]


def test_frame_marks_beam_hits_and_not_beams_that_hit_nothing():
    renderer = FrameRenderer(straight_road(), LANES)
    ego = ego_in_lane(1)
    distances = np.full(24, 100.0)
    distances[0] = 30.0  # beam 0 points straight ahead
    frame = renderer.draw(ego, neighbours([]), [], distances, 100.0, TEXT)
    centre_x, centre_y = ego.front_x - 2.25, LANE_WIDTH
    assert pixel(renderer, frame, (centre_x + 30.0, centre_y), ego) == HIT
    assert pixel(renderer, frame, (centre_x - 100.0, centre_y), ego) != HIT  # beam 12 (behind) hit nothing


def test_the_road_scrolls_with_the_ego_and_the_text_band_reports_the_decision():
    renderer = FrameRenderer(straight_road(), LANES)
    first = renderer.draw(ego_in_lane(1, 500.0), neighbours([]), [], np.full(24, 100.0), 100.0, TEXT)
    moved = renderer.draw(ego_in_lane(1, 503.0), neighbours([]), [], np.full(24, 100.0), 100.0, TEXT)
    band = slice(0, 30)
    assert not np.array_equal(first[40:], moved[40:])  # lane markings moved under the ego
    assert np.array_equal(first[band], moved[band])
    other = renderer.draw(ego_in_lane(1, 500.0), neighbours([]), [], np.full(24, 100.0), 100.0,
                          FrameText(12.5, 30.0, 27.0, 1, LANES, "LANE_LEFT", 4))
    assert not np.array_equal(first[band], other[band])


def test_rgb_array_render_mode_returns_frames_and_other_modes_do_not(small_config):
    env = HighwayEnv(small_config, render_mode="rgb_array")
    try:
        with pytest.raises(RuntimeError, match="reset"):
            env.render()
        env.reset(seed=4)
        first = env.render()
        env.step(0)
        second = env.render()
        assert first.ndim == 3 and first.shape[2] == 3 and first.dtype == np.uint8
        assert first.shape == second.shape and not np.array_equal(first, second)
        assert (first.reshape(-1, 3) == EGO).all(axis=1).sum() > 20  # the ego is drawn
        assert env.metadata["render_fps"] == pytest.approx(1.0 / small_config.env.decision_period_s)
    finally:
        env.close()
    plain = HighwayEnv(small_config)
    try:
        plain.reset(seed=4)
        assert plain.render() is None and plain.frame().shape == first.shape
    finally:
        plain.close()


def test_unknown_render_mode_is_a_clear_error(small_config):
    with pytest.raises(ValueError, match="render_mode must be None, 'human'"):
        HighwayEnv(small_config, render_mode="ansi")


def test_gymnasium_record_video_wrapper_records_an_episode(small_config, tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo writes with moviepy (pip install 'gymnasium[other]')")
    env = gymnasium.wrappers.RecordVideo(
        gymnasium.make(sumo_rail.ENV_ID, config=small_config, render_mode="rgb_array"),
        video_folder=str(tmp_path / "videos"), name_prefix="highway", episode_trigger=lambda episode: True,
        disable_logger=True)
    try:
        env.reset(seed=5)
        for _ in range(6):
            env.step(0)
    finally:
        env.close()
    videos = list((tmp_path / "videos").glob("highway-episode-0.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000
