"""The sweep's Parquet table: one part file per finished trial, combined into results.parquet.

Each finished trial's row is written at once to ``OUT/trials/TRIAL_ID.parquet`` (to a temporary
name, then renamed: a crash or Ctrl-C never leaves half a file, and never loses a finished row);
``combine`` joins the rows of a sweep's trials into ``OUT/results.parquet`` the same way. A
resumed sweep reads the part files to skip the trials that finished ``ok``.

Columns: ``trial_id``, each grid parameter (its dotted name), ``seed``, ``status`` (``ok`` or
``failed``), ``error`` (the traceback; empty when ok), ``retries`` (times a worker died while
running the trial), ``worker``, ``wall_s``, ``sim_time_s``, ``passed``, ``complete``,
``failed_checks`` (the names of the checks that failed, comma-separated), then every flattened
report metric (``fleet.NAME``, float64, null where a trial did not report it; its unit in the
field's metadata ``unit``). A trial with ``status`` ok and ``passed`` false ran but failed its
checks; ``status`` failed means it errored (raised, or its workers kept dying).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from harness.sweep.trial import UNITS_KEY

FIXED_COLUMNS: dict[str, pa.DataType] = {
    "seed": pa.int64(),
    "status": pa.string(),
    "error": pa.string(),
    "retries": pa.int64(),
    "worker": pa.string(),
    "wall_s": pa.float64(),
    "sim_time_s": pa.float64(),
    "passed": pa.bool_(),
    "complete": pa.bool_(),
    "failed_checks": pa.string(),
}
"""Columns of every row after ``trial_id`` and the grid parameters."""

RESULTS_FILE = "results.parquet"
TRIALS_DIR = "trials"


def value_type(values: Iterable[Any]) -> pa.DataType:
    """The Parquet type of a grid parameter's column from its values."""
    values = list(values)
    if all(isinstance(v, bool) for v in values):
        return pa.bool_()
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return pa.int64()
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return pa.float64()
    return pa.string()


def row_schema(parameters: dict[str, pa.DataType], row: dict[str, Any]) -> pa.Schema:
    """The schema of one row: fixed columns, the grid's, then its metrics as float64.

    A metric's unit (the row's ``UNITS_KEY`` entry) is its field's metadata ``unit``.
    """
    units = row.get(UNITS_KEY) or {}
    fields = [pa.field("trial_id", pa.string())]
    fields += [pa.field(name, kind) for name, kind in parameters.items()]
    fields += [pa.field(name, kind) for name, kind in FIXED_COLUMNS.items()]
    known = {"trial_id", UNITS_KEY, *parameters, *FIXED_COLUMNS}
    fields += [
        pa.field(name, pa.float64(), metadata={"unit": units[name]} if name in units else None)
        for name in sorted(row)
        if name not in known
    ]
    return pa.schema(fields)


def unit_of(table: pa.Table, column: str) -> str | None:
    """The unit a column's field metadata gives, or None."""
    metadata = table.schema.field(column).metadata or {}
    unit = metadata.get(b"unit")
    return unit.decode() if unit else None


def _cell(value: Any, kind: pa.DataType) -> Any:
    if kind == pa.string() and value is not None and not isinstance(value, str):
        return str(value)
    return value


def _write_atomic(table: pa.Table, path: Path) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


def write_row(out_dir: Path, parameters: dict[str, pa.DataType], row: dict[str, Any]) -> Path:
    """Write one finished trial's row to ``out_dir/trials/TRIAL_ID.parquet``; returns the path."""
    schema = row_schema(parameters, row)
    cells = {f.name: [_cell(row.get(f.name), f.type)] for f in schema}
    path = Path(out_dir) / TRIALS_DIR / f"{row['trial_id']}.parquet"
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_atomic(pa.table(cells, schema=schema), path)
    return path


def read_row(out_dir: Path, trial_id: str) -> dict[str, Any] | None:
    """The row of a trial written earlier, or None (absent or unreadable: the trial runs again)."""
    path = Path(out_dir) / TRIALS_DIR / f"{trial_id}.parquet"
    if not path.is_file():
        return None
    try:
        rows = pq.read_table(path).to_pylist()
    except (OSError, pa.ArrowException):
        return None
    return rows[0] if rows else None


def combine(out_dir: Path, trial_ids: Iterable[str]) -> pa.Table | None:
    """Join the part files of ``trial_ids`` (in that order) into ``OUT/results.parquet``.

    Trials without a part file (not run yet) are left out; None when there is none at all.
    """
    tables = []
    for tid in trial_ids:
        path = Path(out_dir) / TRIALS_DIR / f"{tid}.parquet"
        if path.is_file():
            try:
                tables.append(pq.read_table(path))
            except (OSError, pa.ArrowException):
                continue
    if not tables:
        return None
    table = pa.concat_tables(tables, promote_options="permissive")
    _write_atomic(table, Path(out_dir) / RESULTS_FILE)
    return table
