"""The per-trial CSV: one row per finished trial, streamed so an interruption loses nothing.

Rows are appended (and flushed) as trials finish, in completion order; a half-written
last line from a killed run is dropped when the table is reopened. At the end of a
sweep the table is rewritten sorted by trial index, so equal seeds give equal files
apart from the timing columns.
"""

from __future__ import annotations

import csv
import dataclasses
import io
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from robot_app.errors import InputError
from robot_app.experiments.trial_result import TrialResult
from robot_app.outputs import atomic_write_text

BASE_COLUMNS = ("index", "seed", "point", "sweep", "status", "reason", "duration_s")
"""Columns of every table; the outcome dataclass's fields follow them."""


def is_timing_column(name: str) -> bool:
    """True for columns that measure time (named `*_s`): they differ between equal runs."""
    return name.endswith("_s")


Row = dict[str, Any]


def _format(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _parse(text: str) -> Any:
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def table_columns(outcome_type: type) -> tuple[str, ...]:
    """The CSV header for an outcome dataclass: `BASE_COLUMNS` then its fields.

    Raises:
        InputError: not a dataclass, or a field named like a base column.
    """
    if not dataclasses.is_dataclass(outcome_type):
        raise TypeError(f"outcome_type must be a dataclass, got {outcome_type!r}")
    fields = tuple(f.name for f in dataclasses.fields(outcome_type))
    clash = set(fields) & set(BASE_COLUMNS)
    if clash:
        raise ValueError(f"outcome fields {sorted(clash)} clash with the table's base columns {BASE_COLUMNS}")
    return BASE_COLUMNS + fields


def read_table(path: str | Path) -> list[Row]:
    """Rows of a per-trial CSV, values parsed back to bool/int/float/str ('' stays '')."""
    file = Path(path)
    if not file.exists() or file.stat().st_size == 0:
        return []
    with file.open(newline="") as stream:
        return [{k: _parse(v) for k, v in row.items()} for row in csv.DictReader(stream)]


class ResultsTable:
    """The CSV file of one sweep, with a fixed header from the outcome dataclass.

    Args:
        path: the CSV file (created on first append).
        outcome_type: the frozen dataclass whose fields follow `BASE_COLUMNS`.
    """

    def __init__(self, path: str | Path, outcome_type: type, *, repair: bool = True) -> None:
        self.path = Path(path)
        self.columns = table_columns(outcome_type)
        self.outcome_fields = self.columns[len(BASE_COLUMNS) :]
        if repair:
            self._repair()

    def complete_lines(self) -> tuple[list[str], int]:
        """(header and complete rows, number of lines in the file), the header checked.

        Raises:
            InputError: the file is not text, or its header is another table's.
        """
        if not self.path.exists() or self.path.stat().st_size == 0:
            return [], 0
        try:
            lines = self.path.read_text(encoding="utf-8").splitlines(keepends=True)
            header = next(csv.reader([lines[0]]))
        except (UnicodeDecodeError, csv.Error) as err:
            raise InputError(
                f"{self.path} is not a text CSV written by robot-app trial ({err}); "
                "choose another --out (or remove it)",
                path=self.path,
                expected="a trials.csv table",
            ) from err
        if tuple(header) != self.columns:
            raise InputError(
                f"{self.path} has columns {header}, expected {list(self.columns)}; "
                "it was written by another trial kind or version; choose another --out",
                path=self.path,
                value=header,
                expected=f"the columns {list(self.columns)}",
            )
        good = [lines[0]]
        for line in lines[1:]:
            try:
                fields = next(csv.reader([line]), [])
            except csv.Error:  # a NUL byte or similar from a killed write: not a row
                continue
            if line.endswith("\n") and len(fields) == len(self.columns) and fields[0].isdigit():
                good.append(line)
        return good, len(lines)

    def complete_indices(self) -> set[int]:
        """Trial indices of the complete rows, without changing the file."""
        good, _ = self.complete_lines()
        return {int(next(csv.reader([line]))[0]) for line in good[1:]}

    def _repair(self) -> None:
        """Checks the header and drops incomplete lines left by a killed run."""
        good, count = self.complete_lines()
        if len(good) != count:
            self._write_atomic("".join(good))

    def _write_atomic(self, text: str) -> None:
        atomic_write_text(self.path, text)

    def finished_indices(self) -> set[int]:
        """Trial indices already in the table (ok or failed)."""
        return {int(row["index"]) for row in self.read_rows()}

    def read_rows(self) -> list[Row]:
        """All rows, values parsed back to bool/int/float/str ('' stays '')."""
        return read_table(self.path)

    def row_of(self, result: TrialResult, sweep_label: str) -> list[str]:
        """The CSV fields of one result."""
        values: list[Any] = [
            result.index,
            result.seed,
            result.point,
            sweep_label,
            result.status,
            result.reason,
            result.duration_s,
        ]
        outcome = result.outcome
        for name in self.outcome_fields:
            values.append(getattr(outcome, name, None) if outcome is not None else None)
        return [_format(v) for v in values]

    @contextmanager
    def appender(self) -> Iterator[Callable[[TrialResult, str], None]]:
        """Opens the table for appending; yields `append(result, sweep_label)`."""
        new = not self.path.exists() or self.path.stat().st_size == 0
        with self.path.open("a", newline="") as file:
            writer = csv.writer(file, lineterminator="\n")
            if new:
                writer.writerow(self.columns)
                file.flush()

            def append(result: TrialResult, sweep_label: str) -> None:
                writer.writerow(self.row_of(result, sweep_label))
                file.flush()

            yield append

    def sort_by_index(self) -> None:
        """Rewrites the table sorted by trial index (one row per index, first kept)."""
        if not self.path.exists():
            return
        with self.path.open(newline="") as file:
            reader = csv.reader(file)
            header = next(reader, None)
            rows = {int(r[0]): r for r in reversed(list(reader))}
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(header or self.columns)
        writer.writerows(rows[i] for i in sorted(rows))
        self._write_atomic(buffer.getvalue())


__all__ = ["BASE_COLUMNS", "ResultsTable", "Row", "is_timing_column", "read_table", "table_columns"]
