"""How deeply a stored JSON text nests, found before it is parsed (issue 26,
findings 4 and 6): ``json.loads`` recurses once per level of ``[`` and
``{``, so a map's ``meta`` or a batch journal's line nested 100,000 deep
ended in ``RecursionError``. :func:`too_deep` counts the brackets outside
string literals, in one linear pass, and stops at the limit.
"""

from __future__ import annotations

import re

#: A JSON string literal (the unrolled form, linear on long strings).
_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_BRACKET = re.compile(r"[\[\]{}]")


def too_deep(text: str, limit: int) -> bool:
    """Whether ``text`` opens more than ``limit`` lists and objects inside
    each other. An unterminated string counts its brackets too: such a text
    is not JSON, and the parser refuses it whatever this says."""
    level = 0
    for bracket in _BRACKET.finditer(_STRING.sub('""', text)):
        if bracket.group() in "[{":
            level += 1
            if level > limit:
                return True
        else:
            level -= 1
    return False
