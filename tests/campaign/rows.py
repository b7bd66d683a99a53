"""Compare stored rows: NaN (a monitor's 'no measured value') must compare equal to itself."""
from __future__ import annotations

import math

from crashscene.campaign import Store


def comparable(rows: list[dict]) -> list[dict]:
    return [{k: ("NaN" if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()} for row in rows]


def table_rows(out, table: str, where: str = "") -> list[dict]:
    """Every row of `table` except the scenario hash, sorted, NaN made comparable."""
    with Store(out, read_only=True) as store:
        return comparable(store.query(f"SELECT * EXCLUDE (scenario_hash) FROM {table} {where} ORDER BY ALL"))
