"""The recovery test (issue 36; `sumo_rail.evaluation.recovery`): every driver on the same held-out seeds in each
start condition (set-point too low, too high, in a lane the expert would leave), how many decisions it takes to
return to the expert's behaviour. One Parquet file per driver, OUT_DIR/NAME.parquet (NAME: the driver's name with
"/" as "__"); a driver whose file exists is skipped, so a run cut short resumes.

Usage: python experiments/recovery.py OUT_DIR DRIVER [DRIVER ...]   (DRIVER: expert or a policy file)
  (environment: EPISODES (default 100), SEED (test seeds from it, default 1000), WORKERS (default 2); the setting is
  the benchmark's: the paper's observation plus the lane block, as its committed policies read it)
"""

from __future__ import annotations

import os
from pathlib import Path

import click
import pyarrow as pa

from sumo_rail.config import Config
from sumo_rail.datasets import write_parquet
from sumo_rail.evaluation.evaluate import DEFAULT_REFERENCE
from sumo_rail.evaluation.protocol import parse_driver
from sumo_rail.evaluation.recovery import HORIZON, LOW_STEPS, RECOVERY_COLUMNS, START_LIMIT, recovery_tasks
from sumo_rail.runners.backends import ProcessPoolBackend
from sumo_rail.runners.tables import provenance
from sumo_rail.seeding import Purpose, episode_seeds

RECOVERY = "recovery"


def main(out: Path, drivers: list[str]) -> None:
    config = Config.from_dict({"observation": {"lane_block": 1}})
    seed = int(os.environ.get("SEED", "1000"))
    seeds = episode_seeds(Purpose.EVALUATE, seed, int(os.environ.get("EPISODES", "100")))
    out.mkdir(parents=True, exist_ok=True)
    with ProcessPoolBackend(int(os.environ.get("WORKERS", "2"))) as backend:
        for text in drivers:
            driver = parse_driver(text, config, DEFAULT_REFERENCE)
            path = out / f"{driver.name.replace('/', '__')}.parquet"
            if path.exists():
                continue
            rows = backend.run(recovery_tasks(config, [driver], DEFAULT_REFERENCE, seeds))
            table = pa.table({"policy": [driver.name] * len(rows),
                              **{name: [row[name] for row in rows] for name in RECOVERY_COLUMNS}})
            write_parquet(table, path, provenance(RECOVERY, config, seed, driver=text, horizon=HORIZON,
                                                  start_limit=START_LIMIT, low_steps=LOW_STEPS))
            print(f"wrote {path}: {len(rows)} episodes", flush=True)


@click.command(help=__doc__)
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.argument("drivers", nargs=-1, required=True)
def cli(out: Path, drivers: tuple[str, ...]) -> None:
    main(out, list(drivers))


if __name__ == "__main__":
    cli()
