"""docs/recordings.md, "Does a written-and-read scene give the env's observation?": the rule-based expert's episodes
of seeds 1-4 on the small road (1500 m, lane block and route block on) captured, written as FCD with 2 and 6
decimals, imported and read back (`sumo_rail.recordings.expert_check`); per episode, the largest difference of a
normalised observation entry and where, and the set-point estimate's largest error.

    python experiments/observation_check.py
"""

from __future__ import annotations

from sumo_rail.config import Config
from sumo_rail.recordings.expert_check import check_in_scratch

CONFIG = Config.from_dict({"scenario": {"length_m": 1500.0, "warmup_s": 120.0, "snapshots": 3,
                                        "snapshot_interval_s": 10.0},
                           "env": {"ego_start_min_m": 300.0, "ego_start_max_m": 500.0},
                           "observation": {"lane_block": 1, "route_block": 1}})
"""tests/recordings/test_expert_check.py's configuration."""


def main() -> None:
    print("| FCD decimals | seed | decisions | with a lane change under way | largest difference | where | set-point "
          "estimate's largest error [m/s] |")
    print("|---|---|---|---|---|---|---|")
    for decimals in (2, 6):
        for seed in (1, 2, 3, 4):
            check = check_in_scratch(CONFIG, seed, decimals)
            worst = max(check.worst_entries, key=lambda name: check.worst_entries[name], default="-")
            print(f"| {decimals} | {seed} | {check.decisions} | {check.lane_changing} | "
                  f"{check.max_abs_difference:.3g} | {worst} | {check.set_point_error_mps:.3f} |")


if __name__ == "__main__":
    main()
