"""`crashscene.traces.write_table`: the same rows give the same bytes however the table is chunked."""
from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from crashscene import traces
from crashscene.traces import TRACE_SCHEMA, write_table


def synthetic_traces(rows: int, seed: int = 0, lane_name: str = "road{}_lane-1") -> pa.Table:
    """A traces table of `rows` rows with what makes Parquet's pages data-dependent: float columns whose
    dictionary outgrows its page mid-column (the writer falls back to plain), strings with nulls, booleans."""
    rng = np.random.default_rng(seed)
    columns = {}
    for field in TRACE_SCHEMA:
        if pa.types.is_floating(field.type):
            few = rng.integers(0, 50, rows) * 0.5  # a small dictionary at first ...
            many = rng.normal(size=rows)  # ... then too many distinct values for one
            columns[field.name] = np.where(np.arange(rows) < rows // 10, few, many)
        elif pa.types.is_integer(field.type):
            columns[field.name] = pa.array(np.arange(rows) // 7, type=field.type)
        elif pa.types.is_boolean(field.type):
            columns[field.name] = rng.random(rows) < 0.1
        else:
            codes = rng.integers(-1, 30, rows)
            columns[field.name] = pa.array([lane_name.format(c) if c >= 0 else None for c in codes.tolist()],
                                           type=pa.string())
    return pa.table(columns, schema=TRACE_SCHEMA)


def rechunked(table: pa.Table, cuts: list[int]) -> pa.Table:
    """`table` cut into chunks at `cuts`, each chunk with buffers of its own (as blocks from different workers)."""
    bounds = [0, *cuts, table.num_rows]
    return pa.Table.from_arrays(
        [pa.chunked_array([pa.concat_arrays([column.combine_chunks().slice(lo, hi - lo)])
                           for lo, hi in zip(bounds, bounds[1:])], type=column.type) for column in table.columns],
        schema=table.schema)


@pytest.mark.parametrize("lane_name", ["road{}_lane-1", "a lane uid far longer than forty bytes, number {}"])
def test_any_chunking_writes_the_bytes_of_one_chunk(tmp_path, lane_name):
    table = synthetic_traces(200_000, lane_name=lane_name)
    (tmp_path / "one").mkdir()
    one = write_table(tmp_path / "one", "traces", table.combine_chunks()).read_bytes()
    rng = np.random.default_rng(1)
    for k, cuts in enumerate([[1], [70_001], sorted(rng.choice(200_000, 12, replace=False).tolist()),
                              [19_999, 20_000, 20_001, 40_000]]):
        (tmp_path / f"cut{k}").mkdir()
        assert write_table(tmp_path / f"cut{k}", "traces", rechunked(table, cuts)).read_bytes() == one, cuts
    back = pq.read_table(tmp_path / "one" / "traces.parquet")
    assert back.schema.equals(TRACE_SCHEMA) and back.num_rows == table.num_rows


def test_pages_are_cut_where_a_page_starts():
    table = rechunked(synthetic_traces(50_000), [5, 30_000])
    aligned = traces._page_aligned(table)
    for column in aligned.columns:
        assert [len(chunk) for chunk in column.chunks] == [20_000, 20_000, 10_000]
    assert aligned.equals(table)  # the same values (the synthetic floats have no NaN)
    long_strings = synthetic_traces(100, lane_name="x" * (traces.ALIGNED_STRING_BYTES + 1) + "{}")
    assert traces._page_aligned(long_strings) is None  # a page of these could end before PAGE_ROWS rows
