"""Concatenate demonstration files recorded on different roads into one (the generalisation table's mixed training
set, specs/generalisation.toml): episodes renumbered in order, the first file's provenance with the files and roads
mixed. Usage: python experiments/mix_demos.py OUT.parquet IN.parquet [IN.parquet ...]"""

from __future__ import annotations

from pathlib import Path

import click
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from sumo_rail.datasets import read_metadata, write_parquet


def main(out: Path, sources: list[Path]) -> None:
    tables, offset = [], 0
    for source in sources:
        table = pq.read_table(source)
        episodes = table.column("episode")
        table = table.set_column(table.schema.get_field_index("episode"), "episode",
                                 pc.add(episodes, pa.scalar(offset, episodes.type)))
        offset += int(pc.max(episodes).as_py()) + 1
        tables.append(table.replace_schema_metadata(None))
    metadata = read_metadata(sources[0]) | {"mixed_from": [str(source) for source in sources],
                                             "mixed_scenarios": [read_metadata(source)["config"]["scenario"]["kind"]
                                                                 for source in sources]}
    mixed = pa.concat_tables(tables)
    write_parquet(mixed, out, metadata)
    print(f"wrote {out}: {mixed.num_rows} decisions of {offset} episodes from {len(sources)} files")


@click.command(help=__doc__)
@click.argument("out", type=click.Path(dir_okay=False, path_type=Path))
@click.argument("sources", nargs=-1, required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path))
def cli(out: Path, sources: tuple[Path, ...]) -> None:
    main(out, list(sources))


if __name__ == "__main__":
    cli()
