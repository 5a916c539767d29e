"""scripts/heap_replay.py on bad input: one line naming the problem, a non-zero exit, no traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "heap_replay.py"


@pytest.mark.parametrize(
    ("args", "expected"),
    [(["--set", "bogus.key=1"], "bogus: unknown key"), (["--rest", "-1"], "--rest must be > 0 s")],
)
def test_bad_input_is_one_line_and_a_failing_exit(args: list[str], expected: str) -> None:
    out = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert expected in out.stderr
    assert "Traceback" not in out.stderr
    assert "slid:" not in out.stdout  # nothing was replayed
