"""`robot-app recognize --pairs PAIRS.csv`: many stereo pairs in one process.

The CSV has a header with the columns `left` and `right` (image paths, relative to the
CSV's folder or absolute). Each row prints one JSON line on stdout, in order, flushed at
once: the recognition record of DESIGN.md with `row` (1 for the first data row), or
`{"row": i, "error": "..."}` when that row's images are missing or unreadable; the other
rows go on. One recogniser serves every row, so the compiled kernels start once. A
progress bar runs on stderr, and at the end one line there says how long the first
result took and the steady time per pair.
"""

from __future__ import annotations

import csv
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np
from tqdm import tqdm

from robot_app.errors import InputError, RobotAppError
from robot_app.vision.photo_model import load_photo
from robot_app.vision.recognizer import Recognizer


@dataclass(frozen=True)
class PairRow:
    """One data row: its number (1 = first data row) and its two image paths."""

    row: int
    left: Path
    right: Path


@dataclass(frozen=True)
class BatchSummary:
    """What a batch did.

    Attributes:
        rows: data rows.
        failed: rows that printed an error.
        first_result_s: from the call to the first line printed [s].
        per_pair_s: median time per pair after the first, image decoding included [s]
            (NaN with fewer than two rows).
    """

    rows: int
    failed: int
    first_result_s: float
    per_pair_s: float


def read_pairs(path: Path) -> list[PairRow]:
    """The rows of a pairs CSV, paths resolved against its folder.

    Raises:
        InputError: no such file, no `left` and `right` columns, or an empty cell.
    """
    if not path.is_file():
        raise InputError(f"pairs file not found: {path}", path=path)
    try:
        with path.open(newline="") as file:
            reader = csv.DictReader(file)
            columns = [c.strip() for c in (reader.fieldnames or [])]
            if "left" not in columns or "right" not in columns:
                raise InputError(
                    f"{path}: the header must name the columns left,right "
                    f"(got {','.join(columns) or 'none'})",
                    path=path,
                    expected="left,right",
                )
            rows = []
            for number, record in enumerate(reader, start=1):
                cells = {(k or "").strip(): (v or "").strip() for k, v in record.items()}
                if not cells.get("left") or not cells.get("right"):
                    raise InputError(
                        f"{path}: row {number} lacks a left or right path", path=path, key=f"row {number}"
                    )
                rows.append(PairRow(number, path.parent / cells["left"], path.parent / cells["right"]))
    except UnicodeDecodeError as err:
        raise InputError(f"{path} is not a text CSV file", path=path) from err
    return rows


def recognize_pairs(
    recognizer: Recognizer,
    rows: list[PairRow],
    *,
    seed: int | None = None,
    report_peaks: bool = False,
    out: TextIO | None = None,
    progress: bool = True,
) -> BatchSummary:
    """Recognises every row, printing one JSON line each (see the module docstring).

    Args:
        recognizer: the model's recogniser (reused for every row).
        rows: from `read_pairs`.
        seed: seed of every row's recognition (None: the recogniser's generator).
        report_peaks: also report each row's peaks.
        out: where the lines go (default stdout).
        progress: show a progress bar on stderr.
    """
    stream = sys.stdout if out is None else out
    start = time.perf_counter()
    stamps: list[float] = []
    failed = 0
    for row in tqdm(rows, desc="pairs", unit="pair", file=sys.stderr, disable=not progress):
        try:
            left, right = load_photo(row.left), load_photo(row.right)
            result = recognizer.recognize(left, right, seed=seed, report_peaks=report_peaks)
            record: dict[str, object] = {"row": row.row, **result.to_json()}
        except RobotAppError as err:
            failed += 1
            record = {"row": row.row, "error": str(err)}
        stream.write(json.dumps(record) + "\n")
        stream.flush()
        stamps.append(time.perf_counter())
    steps = np.diff(stamps)
    summary = BatchSummary(
        rows=len(rows),
        failed=failed,
        first_result_s=stamps[0] - start if stamps else float("nan"),
        per_pair_s=float(np.median(steps)) if len(steps) else float("nan"),
    )
    if progress:
        print(
            f"{summary.rows} pairs, {summary.failed} failed; first result after "
            f"{summary.first_result_s:.2f} s, then {summary.per_pair_s * 1e3:.1f} ms per pair (median)",
            file=sys.stderr,
        )
    return summary


__all__ = ["BatchSummary", "PairRow", "read_pairs", "recognize_pairs"]
