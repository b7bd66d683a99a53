"""The traces table's chunk layout (simulate.embedded.record.canonical_chunks): Parquet's pages follow the
chunks, so the written file has the same bytes however the scenes were split into chunks and worker blocks."""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from crashscene.simulate.embedded.record import TABLE_CHUNK, canonical_chunks

ROWS = 400  # rows per scene (actors x steps)
SCENES = 1100


def _table(splits: list[int]) -> pa.Table:
    """One synthetic trace table, in chunks of `splits` scenes."""
    rng = np.random.default_rng(0)
    x = rng.normal(size=SCENES * ROWS)  # incompressible floats: several pages
    variation = np.repeat(np.arange(SCENES, dtype=np.int32), ROWS)
    bounds = np.cumsum([0] + splits) * ROWS
    return pa.concat_tables([pa.table({"variation": variation[lo:hi], "x": x[lo:hi]})
                             for lo, hi in zip(bounds[:-1], bounds[1:])])


def _parquet(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink, compression="zstd")
    return sink.getvalue().to_pybytes()


def test_any_split_into_chunks_writes_the_same_bytes():
    layouts = [[SCENES], [333, 333, 333, 101], [700, 400], [TABLE_CHUNK, TABLE_CHUNK, 100], [1, 1098, 1]]
    # (on real traces a split moves where a column's dictionary page ends, measured on 2,000 variations of 100237)
    canonical = [canonical_chunks(_table(split), SCENES) for split in layouts]
    assert len({_parquet(table) for table in canonical}) == 1
    for table in canonical:
        assert [len(chunk) for chunk in table.column("x").chunks] == [TABLE_CHUNK * ROWS] * 2 + [100 * ROWS]
        assert table.equals(_table([SCENES]))


def test_an_empty_table_or_uneven_rows_are_left_alone():
    empty = _table([SCENES]).slice(0, 0)
    assert canonical_chunks(empty, 0).num_rows == 0
    uneven = _table([SCENES]).slice(0, SCENES * ROWS - 1)
    assert canonical_chunks(uneven, SCENES) is uneven
