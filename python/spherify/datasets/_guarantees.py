"""What every shape guarantees, written once and appended to each shape's docstring."""

from __future__ import annotations

from typing import Any, Callable, TypeVar

Shape = TypeVar("Shape", bound=Callable[..., Any])

GUARANTEES = """
    The mesh is closed, connected, manifold and of genus 0, with faces
    counter-clockwise seen from outside (positive signed volume), no
    self-intersections, no degenerate or duplicate faces and no coincident
    vertices. The same arguments give the same arrays, bit for bit.
    """


def shape(function: Shape) -> Shape:
    """Append :data:`GUARANTEES` to the docstring's Notes (the signature is kept)."""
    function.__doc__ = (function.__doc__ or "").rstrip() + "\n" + GUARANTEES
    return function
