"""Benchmark: record-expert episodes/s on 1 and 2 workers, and the expert's metrics per style on 16 episodes.

Recording runs exactly what `sumo-rail record-expert` runs (worker start-up included, as a user waits for
it), alternating 1 and 2 workers over rounds; the files are checked to be identical. Writes its section of
docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

from doc_section import write_section

from sumo_rail.config import Config
from sumo_rail.datasets import sumo_version
from sumo_rail.drivers.expert import DEFAULT_STYLE, STYLES
from sumo_rail.evaluation.evaluate import evaluate
from sumo_rail.evaluation.summary import summary_table
from sumo_rail.runners.backends import ProcessPoolBackend
from sumo_rail.runners.record import record_demonstrations
from sumo_rail.runners.rollout import ExpertDriver
from sumo_rail.seeding import Purpose, episode_seeds


def recording_seconds(config: Config, workers: int, episodes: int, out: Path) -> float:
    start = time.perf_counter()
    with ProcessPoolBackend(workers) as backend:
        record_demonstrations(config, ExpertDriver(DEFAULT_STYLE), DEFAULT_STYLE, 0, episodes, backend, out)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=40, help="episodes recorded per run")
    parser.add_argument("--rounds", type=int, default=2, help="alternating 1-worker / 2-worker rounds")
    parser.add_argument("--evaluation-episodes", type=int, default=16)
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks.md"))
    args = parser.parse_args()
    config = Config()
    times: dict[int, list[float]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory() as folder:
        recording_seconds(config, 1, 1, Path(folder) / "warm.parquet")  # network and warm states, untimed
        for round_ in range(args.rounds):
            for workers in (1, 2):
                out = Path(folder) / f"{workers}_{round_}.parquet"
                times[workers].append(recording_seconds(config, workers, args.episodes, out))
        files = {path.read_bytes() for path in Path(folder).glob("[12]_*.parquet")}
    rate = {workers: args.episodes / statistics.median(seconds) for workers, seconds in times.items()}
    seeds = episode_seeds(Purpose.EVALUATE, 1000, args.evaluation_episodes)
    with ProcessPoolBackend(2) as backend:
        metrics = evaluate([ExpertDriver(style) for style in STYLES], config, seeds, backend).metrics
    section = f"""
## Expert recording and the expert's styles (issue 3)

Command: `make bench` (runs `{' '.join(['python', *sys.argv])}`).
Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, SUMO {sumo_version()}.
Default scenario and style ({DEFAULT_STYLE}); {args.episodes} episodes a run, worker start-up included,
median of {args.rounds} alternating rounds.

| workers | wall time [s] | episodes/s |
|---|---|---|
| 1 | {statistics.median(times[1]):.1f} | {rate[1]:.2f} |
| 2 | {statistics.median(times[2]):.1f} | {rate[2]:.2f} |

Speed-up with 2 workers: **{rate[2] / rate[1]:.2f}x** (target >= 1.8x). The {2 * args.rounds}
recordings were {"byte-identical" if len(files) == 1 else "NOT identical"}.

The expert's metrics per style, {args.evaluation_episodes} evaluation episodes each (seeds of the evaluation
class from base 1000, as `sumo-rail evaluate --policy expert:STYLE --episodes {args.evaluation_episodes}`),
mean [95% interval] over episodes and each style's paired difference to the first:

```
{summary_table(metrics)}
```
"""
    write_section(args.out, "record", section)


if __name__ == "__main__":
    main()
