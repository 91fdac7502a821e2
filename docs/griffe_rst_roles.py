"""A griffe extension for the API reference (mkdocs.yml): the docstrings
cross-reference in Sphinx's way (``:func:`embed```, ``:class:`~spherify.Mesh```),
which Markdown would print as written; each such role becomes inline code."""

from __future__ import annotations

import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:py:)?(?:func|class|meth|attr|data|mod|exc|obj|const):`~?([^`]+)`")


class RstRoles(griffe.Extension):
    """Rewrites ``:role:`name``` as ```name``` in every docstring."""

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        if obj.docstring is not None:
            obj.docstring.value = ROLE.sub(r"`\1`", obj.docstring.value)
