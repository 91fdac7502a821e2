"""The sizes spherify's applications take, stated once (issue 26, finding 5).

Every size that comes from an argument (a level, an image size, a frame or
sample count) is checked against these bounds before anything is allocated,
and a size outside them is a :class:`MeshError` naming the argument and the
bound (exit status 2 on the command line). Each bound is chosen so that the
call at the bound runs in a process limited to 4 GB of address space
(tests/test_limits.py runs them there): the documented range is the range
that works, not a range that aborts.

| argument | bound | at the bound |
|---|---|---|
| ``remesh`` / ``remesh_map`` ``level`` | 9 | 2,621,442 vertices |
| ``geometry_image`` ``size`` | 4097 | 16.8 M pixels, 400 MB per (size, size, 3) array |
| ``UVLayout.bake`` / ``texture --size`` height | 4096 | a 4096 x 6144 cube atlas, 600 MB |
| ``morph --frames`` | 1000 | 1000 files |
| ``surface_distance`` ``samples`` / ``remesh --samples`` | 10,000,000 | a few seconds per million, in chunks |

The size of a mesh has no fixed bound: what a map of it needs depends on the
method and on what the process can get. Its estimate is checked before the
map starts (``crates/sphere/src/memory_budget.rs``, docs/reliability.md,
"Memory"), and one that cannot fit is a :class:`ResourceError` naming the call,
the vertex count and the bytes (exit status 1 on the command line).
"""

from __future__ import annotations

__all__ = ["ATLAS_HEIGHT_MAX", "DISTANCE_SAMPLES_MAX", "GEOMETRY_IMAGE_SIZE_MAX",
           "MORPH_FRAMES_MAX", "REMESH_LEVEL_MAX"]

REMESH_LEVEL_MAX = 9
GEOMETRY_IMAGE_SIZE_MAX = 4097
ATLAS_HEIGHT_MAX = 4096
MORPH_FRAMES_MAX = 1000
DISTANCE_SAMPLES_MAX = 10_000_000
