"""Every public name has a docstring (issue 24, item 6): what the API reference
(``mkdocs build --strict`` in ``.ci/run``, pages in ``docs/api/``) is made from.

Public means listed in ``__all__`` of ``spherify`` or one of its public
submodules; for a public class, also its methods and properties whose names do
not start with ``_``. A constant (a tuple or string) carries a ``#:`` comment
on the line above its assignment, which the reference shows as its docstring.
"""

from __future__ import annotations

import inspect
import re
import types
from pathlib import Path
from typing import Any, Iterator, List, Tuple

import pytest

import spherify as sp

ROOT = Path(__file__).resolve().parent.parent
MODULES = [sp, sp.harmonics, sp.texture, sp.plot, sp.datasets]
#: Names whose documentation is a sentence of their page instead of a docstring.
NOT_DOCUMENTED_BY_DOCSTRING = {"spherify.__version__"}


def public_names() -> Iterator[Tuple[types.ModuleType, str, Any]]:
    for module in MODULES:
        for name in module.__all__:
            yield module, name, getattr(module, name)


def class_members(cls: type) -> Iterator[Tuple[str, Any]]:
    for name, member in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(member, (staticmethod, classmethod)):
            member = member.__func__
        if isinstance(member, property) or inspect.isfunction(member):
            yield name, member


def has_doc(obj: Any) -> bool:
    doc = obj.__doc__ if isinstance(obj, property) else inspect.getdoc(obj)
    return bool(doc and doc.strip())


def test_every_submodule_page_exists() -> None:
    for module in MODULES:
        page = "spherify" if module is sp else module.__name__.split(".")[-1]
        text = (ROOT / "docs" / "api" / f"{page}.md").read_text()
        assert f"::: {module.__name__}\n" in text


def test_every_public_name_has_a_docstring() -> None:
    missing: List[str] = []
    for module, name, obj in public_names():
        qualified = f"{module.__name__}.{name}"
        if qualified in NOT_DOCUMENTED_BY_DOCSTRING:
            continue
        if inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj):
            if not has_doc(obj) or (inspect.isclass(obj) and obj.__doc__ is None):
                missing.append(qualified)
            if inspect.isclass(obj):
                missing += [f"{qualified}.{member}" for member, value in class_members(obj)
                            if not has_doc(value)]
        else:
            source = inspect.getsource(module)
            if not re.search(rf"^#:.*\n{re.escape(name)}\b.*=", source, re.MULTILINE):
                missing.append(f"{qualified} (a constant: '#:' comment above it)")
    assert missing == [], f"public names without a docstring: {missing}"


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_the_module_itself_has_a_docstring(module: types.ModuleType) -> None:
    assert has_doc(module)
