"""Sizes of an ``.npz`` checked before anything is inflated (issue 26,
finding 3): the one idea of this module is :func:`check_npz` (and
:func:`check_npy`, the same for a plain ``.npy`` file).

``np.load`` of an ``.npz`` member allocates the whole array its ``.npy``
header declares and then inflates the member into it: a 2.6 KB file whose
header declared 10^11 rows raised numpy's ``MemoryError`` (2.18 TiB), and
1.17 MB of deflated zeros declared as 50M points took 2.4 GB and 14 s.
:func:`check_npz` reads only the zip's central directory and each member's
``.npy`` header (at most numpy's 10,000 header bytes), and refuses, with a
:class:`FormatError` naming the file, a member whose declared array

* holds more than :data:`MAX_ELEMENTS` elements (the documented limit), or
* does not fit in the member's stated uncompressed size (``file_size``), or
  comes from a member whose ``file_size`` its compressed bytes could not
  inflate to: deflate expands at most :data:`DEFLATE_RATIO` : 1, a stored
  member not at all, and ``compress_size`` itself cannot exceed the file.

So an array that is allocated is at most about 1032 times the size of the
file it comes from, and at most :data:`MAX_ELEMENTS` elements, whatever the
file declares. Members compressed otherwise (bzip2, lzma: no such bound,
numpy never writes them: ``NotImplementedError``, as ``zipfile`` raises for
a method it does not know) and arrays of Python objects (pickles) are
refused.
"""

from __future__ import annotations

import io
import math
import os
import warnings
import zipfile
from typing import IO, Callable, Dict, Tuple

import numpy as np

from ._errors import FormatError

#: The most elements one stored array may declare: four columns of the
#: core's largest vertex count (``MAX_VERTICES``, 2^32 - 1).
MAX_ELEMENTS = 4 * (2**32 - 1)
#: The longest .npy header read (numpy's own limit is 10,000 characters).
MAX_HEADER_BYTES = 1 << 16
#: Deflate's largest expansion: 258 bytes from at least 2 bits, 1032 : 1.
DEFLATE_RATIO = 1032
#: Bytes of a deflate stream that are not data (block headers, the end).
DEFLATE_SLACK = 64


def _header(member: IO[bytes]) -> Tuple[Tuple[int, ...], np.dtype, int]:
    """The declared shape and dtype of an ``.npy`` stream and the bytes its
    header took. The header's length is checked before the header is read
    (numpy would read whatever length a version 2 header states, up to 4 GB).
    Raises ValueError (and whatever ``ast`` and ``tokenize`` raise on a
    header that is not a literal) for a malformed header."""
    prefix = member.read(8)
    if len(prefix) < 8 or prefix[:6] != b"\x93NUMPY":
        raise ValueError("not an .npy array (no \\x93NUMPY magic)")
    version = (prefix[6], prefix[7])
    if version not in ((1, 0), (2, 0), (3, 0)):
        raise ValueError(f"unknown .npy format version {version}")
    width = 2 if version == (1, 0) else 4
    length_field = member.read(width)
    length = int.from_bytes(length_field, "little")
    if len(length_field) < width or length > MAX_HEADER_BYTES:
        raise ValueError(f"a header of {length:,} bytes (at most {MAX_HEADER_BYTES:,} are read)")
    header = member.read(length)
    if len(header) < length:
        raise ValueError("the header is cut short")
    parse = io.BytesIO(length_field + header)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a Python 2 header: parsed again by np.load
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(parse)
        else:
            # 3.0 is 2.0 with a UTF-8 header (numpy writes it only for
            # structured dtypes with non-Latin-1 field names).
            shape, _, dtype = np.lib.format.read_array_header_2_0(parse)
    return shape, dtype, 8 + width + length


#: What :func:`check_npz` found: each ``.npy`` member's declared shape, by
#: the name ``np.load`` gives it (``V`` for ``V.npy``).
Shapes = Dict[str, Tuple[int, ...]]


def check_npz(handle: IO[bytes], source: str) -> Shapes:
    """Refuse (``FormatError`` naming ``source``) an ``.npz`` open as
    ``handle`` whose members declare arrays larger than they can hold or
    than :data:`MAX_ELEMENTS` (module docstring). Reads the central
    directory and the ``.npy`` headers only; leaves ``handle`` at its start.
    Zip damage (``BadZipFile``, ...) propagates for the caller's
    ``_formats.damaged_archive``. Returns the declared shapes, for a reader
    that knows how they must agree (``load_map``: one point per vertex)."""
    shapes: Shapes = {}
    def fail(why: str) -> FormatError:
        return FormatError(f"{source}: {why}", source)

    # The archive's size: of the open file, or of bytes in memory (a pickled
    # map, _persist.unpickle_map), by seeking to the end.
    archive_bytes = handle.seek(0, os.SEEK_END)
    handle.seek(0)
    with zipfile.ZipFile(handle) as archive:
        for info in archive.infolist():
            name = info.filename
            if info.compress_type == zipfile.ZIP_STORED:
                most = info.compress_size
            elif info.compress_type == zipfile.ZIP_DEFLATED:
                most = DEFLATE_RATIO * info.compress_size + DEFLATE_SLACK
            else:
                # As zipfile says of a method it does not know; the readers
                # turn it into their FormatError of a damaged archive.
                raise NotImplementedError(f"member {name!r} is compressed with zip method "
                                          f"{info.compress_type}; only stored and deflated "
                                          "members are read")
            if info.compress_size > archive_bytes:
                raise fail(f"member {name!r} says it has {info.compress_size:,} compressed "
                           f"bytes; the file has {archive_bytes:,}")
            if info.file_size > most:
                raise fail(f"member {name!r} says it inflates to {info.file_size:,} bytes; "
                           f"its {info.compress_size:,} compressed bytes hold at most {most:,}")
            if not name.endswith(".npy"):
                continue  # np.load reads it as raw bytes, bounded above
            with archive.open(info) as member:
                try:
                    shape, dtype, offset = _header(member)
                except zipfile.BadZipFile:
                    raise
                except Exception as err:
                    # A header that is not a literal: ValueError, and from
                    # ast / tokenize SyntaxError, TokenError, RecursionError,
                    # MemoryError (found by the fuzzer and by hand, issue 26).
                    raise fail(f"member {name!r} has a malformed .npy header "
                               f"({type(err).__name__}: {err})") from None
            _check_array(f"member {name!r}", shape, dtype, info.file_size - offset, fail)
            shapes[name[:-len(".npy")]] = tuple(shape)
    handle.seek(0)
    return shapes


def _check_array(what: str, shape: Tuple[int, ...], dtype: np.dtype, available: int,
                 fail: Callable[[str], FormatError]) -> None:
    """Refuse a declared array of objects, of a negative shape, of more than
    :data:`MAX_ELEMENTS` elements, or of more bytes than ``available``."""
    if dtype.hasobject:
        raise fail(f"{what} holds Python objects (a pickle), which are never loaded")
    if any(n < 0 for n in shape):
        raise fail(f"{what} declares the shape {shape}")
    count = math.prod(shape)
    if count > MAX_ELEMENTS:
        raise fail(f"{what} declares {count:,} elements (shape {shape}); "
                   f"at most {MAX_ELEMENTS:,} are read")
    if count * dtype.itemsize > available:
        raise fail(f"{what} declares shape {shape} of {dtype} ({count * dtype.itemsize:,} "
                   f"bytes), more than its {max(available, 0):,} bytes of data hold")


def check_npy(handle: IO[bytes], source: str) -> None:
    """The same for an ``.npy`` file open as ``handle``: its declared array
    must fit :data:`MAX_ELEMENTS` and the bytes after its header (numpy
    allocated 2.18 TiB for a 1 kB file declaring 10^11 rows). Leaves
    ``handle`` at its start. A file that is no ``.npy`` is left to numpy."""
    def fail(why: str) -> FormatError:
        return FormatError(f"{source}: {why}", source)

    size = os.fstat(handle.fileno()).st_size
    handle.seek(0)
    if handle.read(6) != b"\x93NUMPY":
        handle.seek(0)
        return
    handle.seek(0)
    try:
        shape, dtype, offset = _header(handle)
    except Exception as err:  # as for a member of an .npz (check_npz)
        raise fail(f"malformed .npy header ({type(err).__name__}: {err})") from None
    _check_array("the array", shape, dtype, size - offset, fail)
    handle.seek(0)
