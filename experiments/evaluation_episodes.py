"""How many evaluation episodes the expert's mean overtakes needs for a 95% interval within +-10% of itself.

Usage: `sumo-rail evaluate --policy expert --episodes 300 --workers 2 --out expert300.parquet` then
`python experiments/evaluation_episodes.py expert300.parquet`: prints, for the first n episodes, the mean of each
paper metric and the half-width of its 95% interval relative to the mean.
"""

from __future__ import annotations

import click
import pandas as pd

from sumo_rail.evaluation.statistics import interval, mean_sample

COUNTS = (16, 50, 100, 150, 200, 300)
METRICS = ("overtakes", "lane_changes", "average_speed_kmh")


def main(path: str) -> None:
    metrics = pd.read_parquet(path).sort_values("episode")
    print("| episodes | " + " | ".join(f"{name}: mean, half-width / mean" for name in METRICS) + " |")
    print("|---:|" + "---|" * len(METRICS))
    for count in (n for n in COUNTS if n <= len(metrics)):
        cells = []
        for name in METRICS:
            found = interval(mean_sample(metrics[name].to_numpy()[:count]), seed=0)
            cells.append(f"{found.estimate:.2f}, +-{100 * (found.high - found.low) / 2 / found.estimate:.1f}%")
        print(f"| {count} | " + " | ".join(cells) + " |")


@click.command(help=__doc__)
@click.argument("path", type=click.Path(exists=True, dir_okay=False))
def cli(path: str) -> None:
    main(path)


if __name__ == "__main__":
    cli()
