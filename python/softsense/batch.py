"""Batch items one at a time: what ``softsense batch`` does for each item of a manifest,
for running the items somewhere else, such as tasks on a Ray cluster
(``python/examples/ray_batch.py``, docs/scale-out.md).

Each item ends in ``OUT/results/ID.json``, written atomically exactly as ``softsense
batch`` writes it, so a folder filled by Ray tasks resumes with ``softsense batch`` and the
other way round.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Dict, List, Tuple

from . import _softsense
from ._args import PathLike, keywords, path

__all__ = ["Plan", "plan", "run_item"]


@dataclass
class Plan:
    """The items still to run (ids, in manifest order), and those a result file answers:
    ``done``, ``failed`` (``(id, error)``, not retried unless asked) and ``replaced``
    (result files of another item or unreadable: run again)."""

    todo: List[str]
    done: int
    failed: List[Tuple[str, str]]
    replaced: int


@keywords
def plan(manifest: PathLike, out: PathLike, retry_failed: bool = False) -> Plan:
    """What is left to do of ``manifest`` with results in ``out``."""
    todo, done, failed, replaced = _softsense.batch_plan(path(manifest, "manifest", must_exist=True), path(out, "out"), retry_failed)
    return Plan(todo=todo, done=done, failed=failed, replaced=replaced)


@keywords
def run_item(manifest: PathLike, item_id: str, out: PathLike, window: int = 1) -> Dict[str, Any]:
    """Runs one item of ``manifest`` and writes its result file in ``out``; returns
    ``{"id", "frames", "sensed", "error", "seconds"}`` (``error`` is None when it was done).
    ``window`` frames are sensed side by side; the result does not depend on it."""
    return _softsense.batch_run_item(path(manifest, "manifest", must_exist=True), item_id, path(out, "out"), window)
