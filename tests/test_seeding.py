import itertools

import pytest

from sumo_rail.seeding import Purpose, episode_seeds


def test_recording_evaluation_and_training_never_share_an_episode_whatever_the_base_seeds():
    """The promise commands.md makes: evaluation seeds never coincide with recording (or training) seeds, for any
    base seeds and episode counts; and a job's own episodes are all different."""
    seeds = {purpose: {seed for base in range(0, 60, 7) for seed in episode_seeds(purpose, base, 40)}
             for purpose in Purpose}
    for first, second in itertools.combinations(Purpose, 2):
        assert not seeds[first] & seeds[second], (first, second)
    assert all(len(set(episode_seeds(purpose, 5, 100))) == 100 for purpose in Purpose)


def test_a_negative_base_seed_is_refused():
    with pytest.raises(ValueError, match="must not be negative"):
        episode_seeds(Purpose.RECORD, -1, 3)
