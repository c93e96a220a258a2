"""Generated recordings: ``scene.generate`` and ``scene.sweep`` are ``softsense scene
generate`` and ``softsense scene sweep`` (the scene and sweep file formats are in
docs/recording-format.md and docs/accuracy.md)."""

from __future__ import annotations

import json
from typing import Any, Dict, List

from . import _softsense
from ._args import PathLike, keywords, path

__all__ = ["generate", "sweep"]


@keywords
def generate(spec: PathLike, out: PathLike) -> Dict[str, Any]:
    """Generates the recording the scene file ``spec`` describes into the folder ``out``;
    returns its truth (the content of ``truth.json``)."""
    return json.loads(_softsense.scene_generate(path(spec, "spec", must_exist=True), path(out, "out")))


@keywords
def sweep(spec: PathLike, out: PathLike, count: int, seed: int) -> List[Dict[str, Any]]:
    """Draws ``count`` random scenes of the sweep file ``spec`` with ``seed`` into the new
    or empty folder ``out``, one recording each; returns what was drawn for each scene (as
    ``draws.json``)."""
    return json.loads(_softsense.scene_sweep(path(spec, "spec", must_exist=True), path(out, "out"), int(count), int(seed)))
