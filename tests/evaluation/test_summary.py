import numpy as np
import pandas as pd

from sumo_rail.evaluation.summary import closeness


def test_closeness_verdicts_between_two_drivers():
    rng = np.random.default_rng(3)
    seeds = np.arange(80)
    expert = rng.normal(2.4, 1.0, 80)
    frames = [pd.DataFrame({"policy": name, "seed": seeds, **{m: values for m in ("overtakes", "lane_changes")}})
              for name, values in (("expert", expert), ("rail", expert + rng.normal(0.05, 0.1, 80)),
                                   ("bc", expert + rng.normal(-1.0, 0.1, 80)))]
    metrics = pd.concat(frames, ignore_index=True)
    metrics["lane_changes"] = np.where(metrics["policy"] == "expert", 1.0, 1.0 + rng.normal(0, 0.01, len(metrics)))
    table = closeness(metrics, "rail", "bc", "expert").set_index("measure")
    assert table.loc["overtakes", "verdict"] == "closer"
    assert table.loc["lane_changes", "verdict"] == "no detectable difference"
    assert closeness(metrics, "bc", "rail", "expert").set_index("measure").loc["overtakes", "verdict"] == "further"


def test_a_road_with_a_feature_reports_its_route_measures_even_when_nothing_failed():
    """Every exit taken well ahead of the diverge (no merge counted) and no failure: on a road with a feature the
    summary still says 0 failures and 0 missed exits; on the straight road those rows stay out."""
    from sumo_rail.evaluation.summary import EPISODE_MEASURES, summary_table

    episodes = pd.DataFrame({"policy": ["expert"] * 4 + ["bc"] * 4, "seed": list(range(4)) * 2,
                             **{name: np.ones(8) for name in EPISODE_MEASURES}, "collisions": np.zeros(8),
                             "merges": np.zeros(8), "merge_time_s": np.zeros(8), "missed_exits": np.zeros(8),
                             "lane_end_stops": np.zeros(8)})
    straight, exit_road = summary_table(episodes), summary_table(episodes, route=True)
    for measure in ("failures", "missed_exits", "lane_end_stops"):
        assert measure not in straight
        assert exit_road.count(f"\n{measure} ") == 2, exit_road  # the means and the differences
    episodes.loc[5, "missed_exits"] = 1  # a failure shows on any road
    assert "missed_exits" in summary_table(episodes)


def test_a_difference_over_too_few_seeds_is_n_a_never_detectable():
    """The issue's "+14.00 [+14.00, +14.00] *" from alike episodes: below MIN_PAIRS seeds in common the difference
    prints "n/a" as its interval, unstarred, and the table says why; from MIN_PAIRS on it is starred."""
    from sumo_rail.evaluation.statistics import MIN_PAIRS
    from sumo_rail.evaluation.summary import DETECTABLE, summary_table

    def differences(seeds: int) -> tuple[str, str]:
        """The heading of the differences and the cell of steps."""
        episodes = pd.DataFrame({"policy": ["expert"] * seeds + ["bc"] * seeds, "seed": list(range(seeds)) * 2,
                                 "steps": [1.0] * seeds + [15.0] * seeds})
        heading, grid = summary_table(episodes).split("difference to expert")[1].split(":\n")
        return heading, next(line for line in grid.splitlines() if line.startswith("steps "))[6:].strip()

    for seeds in (1, 2, MIN_PAIRS - 1):
        heading, cell = differences(seeds)
        assert cell == "+14.00 [n/a]" and f"n/a: fewer than {MIN_PAIRS} seeds in common" in heading
    heading, cell = differences(MIN_PAIRS)
    assert cell == f"+14.00 [+14.00, +14.00] {DETECTABLE}" and "fewer than" not in heading
