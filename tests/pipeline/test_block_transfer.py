"""How a forked worker hands its payload to the parent (`_send` / `_receive`): through a memory file (`_Spill`) or
the pipe, the parent gets equal tables and objects, empty buffers and several messages included."""
from __future__ import annotations

import multiprocessing

import numpy as np
import pyarrow as pa
import pytest

from crashscene.pipeline.simulate import _receive, _send, _Spill
from crashscene.simulate.backend import BatchResult


def _payloads() -> list[tuple[str, object]]:
    rng = np.random.default_rng(5)
    n = 50_000
    big = pa.table({"x": rng.random(n), "actor": pa.array(["ego", "npc1"] * (n // 2)),
                    "maybe": pa.array([None if k % 7 else float(k) for k in range(n)], type=pa.float64()),
                    "flag": pa.array(rng.random(n) < 0.5)})
    empty = pa.table({"x": pa.array([], type=pa.float64()), "s": pa.array([], type=pa.string())})
    # an empty table last: its buffers are empty and would lie past the end of the file
    return [("tables", BatchResult(backend="embedded", tables={"traces": big, "none": empty})),
            ("judged", {"rows": big.slice(123, 4567), "note": "text", "empty": empty}),
            ("error", ValueError("a worker's error"))]


def _child(send, spill) -> None:
    for kind, payload in _payloads():
        _send(send, kind, payload, spill)
    send.close()


@pytest.mark.parametrize("memory_file", [True, False], ids=["memfd", "pipe"])
def test_payloads_arrive_equal(memory_file):
    spill = _Spill.create(0) if memory_file else None
    if memory_file and spill is None:
        pytest.skip("no memfd on this platform")
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    process = context.Process(target=_child, args=(send, spill))
    process.start()
    send.close()
    got = [_receive(receive, spill) for _ in range(3)]
    process.join()
    if spill is not None:
        spill.close()  # the mapped buffers outlive the file's descriptor
    want = _payloads()
    assert [kind for kind, _ in got] == [kind for kind, _ in want]
    result = got[0][1]
    assert result.tables["traces"].equals(want[0][1].tables["traces"])
    assert result.tables["none"].equals(want[0][1].tables["none"]) and result.tables["none"].num_rows == 0
    judged = got[1][1]
    assert judged["rows"].equals(want[1][1]["rows"]) and judged["note"] == "text" and judged["empty"].num_rows == 0
    assert isinstance(got[2][1], ValueError) and str(got[2][1]) == "a worker's error"
    assert sum(result.tables["traces"].column("x").to_numpy()) == pytest.approx(
        sum(want[0][1].tables["traces"].column("x").to_numpy()))
