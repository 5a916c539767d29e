"""Simulations that depend only on their own inputs: each run in a fresh process.

pybullet's deformable world carries state from one world to the next inside a process:
neither `disconnect` nor `resetSimulation` clears it. The same pile of soft cloths, built
again after another world ran, settles differently from physics step 11 on (issue 17g:
three piles in one process settled in 0.6, 0.4 and 0.8 s, where every fresh process gave
the same sequence). A run that builds soft bodies therefore repeats only when it is the
first world of its process. Runs that must repeat (bench episodes, physics checks, tests
that assert a pile's behaviour) go through here; `fn` must be a module-level function
(picklable by reference) and its arguments and result picklable.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from multiprocessing.pool import Pool
from typing import Any, TypeVar

T = TypeVar("T")


def fresh_process_pool(workers: int) -> Pool:
    """A spawn-context pool whose workers each run one task and exit, so every task is the
    first in its process (`maxtasksperchild=1`; spawn, not fork, so no parent state is copied)."""
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    return mp.get_context("spawn").Pool(workers, maxtasksperchild=1)


def run_in_fresh_process(fn: Callable[..., T], *args: Any) -> T:
    """`fn(*args)` in a fresh process of its own; its exception is raised here."""
    with fresh_process_pool(1) as pool:
        return pool.apply(fn, args)


__all__ = ["fresh_process_pool", "run_in_fresh_process"]
