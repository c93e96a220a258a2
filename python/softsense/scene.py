"""Generated recordings: ``scene.generate`` and ``scene.sweep`` are ``softsense scene
generate`` and ``softsense scene sweep`` (the scene and sweep file formats are in
docs/recording-format.md and docs/accuracy.md)."""

from __future__ import annotations

import json
from typing import Any, Dict, List

from . import _softsense

__all__ = ["generate", "sweep"]


def generate(spec: str, out: str) -> Dict[str, Any]:
    """Generates the recording the scene file ``spec`` describes into the folder ``out``;
    returns its truth (the content of ``truth.json``)."""
    return json.loads(_softsense.scene_generate(str(spec), str(out)))


def sweep(spec: str, out: str, count: int, seed: int) -> List[Dict[str, Any]]:
    """Draws ``count`` random scenes of the sweep file ``spec`` with ``seed`` into the new
    or empty folder ``out``, one recording each; returns what was drawn for each scene (as
    ``draws.json``)."""
    return json.loads(_softsense.scene_sweep(str(spec), str(out), int(count), int(seed)))
