"""A plain text progress bar for long core calls (no dependency).

The core calls a progress callable with ``(done, total)`` at most about 100
times per run, from worker threads, one call at a time (STYLE 17: the core
prints nothing; Python renders).
"""

from __future__ import annotations

import sys
import time
from typing import Any, Callable, Optional, TextIO

from ._errors import MeshError

ProgressCallback = Callable[[int, int], Any]


class TextProgress:
    """Draws ``label [#####.....]  45%  4500/10000  12.3 s`` on one line of
    ``stream`` (stderr by default), redrawn at most 20 times per second, and
    ends the line when ``done == total``."""

    def __init__(self, label: str, stream: Optional[TextIO] = None, width: int = 30) -> None:
        self.label = label
        self.stream = stream
        self.width = width
        self.start = time.perf_counter()
        self.drawn = -1.0

    def __call__(self, done: int, total: int) -> None:
        now = time.perf_counter()
        if done < total and now - self.drawn < 0.05:
            return
        self.drawn = now
        fraction = done / total if total else 1.0
        filled = int(round(fraction * self.width))
        bar = "#" * filled + "." * (self.width - filled)
        stream = self.stream if self.stream is not None else sys.stderr
        stream.write(f"\r{self.label} [{bar}] {int(100 * fraction):3d}%  {done}/{total}  "
                     f"{now - self.start:.1f} s")
        if done >= total:
            stream.write("\n")
        stream.flush()


def as_callback(progress: object, label: str) -> Optional[ProgressCallback]:
    """``True`` -> a :class:`TextProgress` on stderr; ``None`` / ``False`` ->
    None; a callable -> itself."""
    if progress is None or progress is False:
        return None
    if progress is True:
        return TextProgress(label)
    if callable(progress):
        return progress
    raise MeshError("progress must be True, False, None or a callable taking (done, total), "
                    f"got {type(progress).__name__}")


#: Rows per call when a long ``to_surface`` is cut into pieces for its bar.
CHUNK_ROWS = 20_000


def to_surface_in_chunks(m: Any, points: Any, progress: object, label: str) -> Any:
    """``m.to_surface(points)`` (the three arrays), in pieces of
    :data:`CHUNK_ROWS` rows when ``progress`` asks for a bar or a callable,
    which then receives ``(rows done, rows)`` after each piece. Point location
    is row by row, so the pieces give the same arrays as one call; the first
    piece also builds the map's locator, once."""
    import numpy as np

    callback = as_callback(progress, label)
    if callback is None:
        return m.to_surface(points)
    rows = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    total = len(rows)
    parts = []
    for start in range(0, total, CHUNK_ROWS):
        parts.append(m.to_surface(rows[start:start + CHUNK_ROWS]))
        callback(min(start + CHUNK_ROWS, total), total)
    if not parts:
        result = m.to_surface(rows)
        callback(0, 0)
        return result
    return tuple(np.concatenate([part[k] for part in parts]) for k in range(3))
