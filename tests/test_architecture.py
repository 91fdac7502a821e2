"""ARCHITECTURE.md names every source file, and no file that does not exist
(issue 25, item 5): the code map cannot drift from the tree.

The code map's folders are headings of the form ``### `folder/` ``; under
each, a list item per file starts with its name in backticks, relative to
that folder (``- `dijkstra.rs`: ...``)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Set, Tuple

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "ARCHITECTURE.md"

#: Where source files live, and which files count there.
SOURCE_FOLDERS = ["crates", "python", "benches", "examples", "tests", ".ci"]
SUFFIXES = {".rs", ".py", ".pyi"}
#: Build output and caches inside those folders, never source.
SKIPPED_PARTS = {"target", "__pycache__", ".hypothesis", ".pytest_cache", ".mypy_cache"}


def source_files(root: Path) -> Set[str]:
    found = set()
    for top in SOURCE_FOLDERS:
        for path in (root / top).rglob("*"):
            if not path.is_file() or SKIPPED_PARTS & set(path.relative_to(root).parts):
                continue
            if path.suffix in SUFFIXES or path.relative_to(root).as_posix() == ".ci/run":
                found.add(path.relative_to(root).as_posix())
    return found


def named_files(text: str) -> Tuple[Set[str], Set[str]]:
    """The files the code map names (folder + name), and the folders it has."""
    folder = None
    names: Set[str] = set()
    folders: Set[str] = set()
    for line in text.splitlines():
        heading = re.match(r"^#{2,4} `([^`]+)/`\s*$", line)
        if heading:
            folder = heading.group(1)
            folders.add(folder)
            continue
        if line.startswith("#"):
            folder = None
            continue
        item = re.match(r"^\s*- `([^`]+)`", line)
        if item and folder is not None:
            names.add(f"{folder}/{item.group(1)}")
    return names, folders


def test_the_parser_sees_folders_and_items() -> None:
    names, folders = named_files("## Code map\n### `crates/mesh/src/`\n- `cut.rs`: cutting\n"
                                 "  - `io/obj.rs`: OBJ\n## Invariants\n- `x.rs` not a file\n")
    assert names == {"crates/mesh/src/cut.rs", "crates/mesh/src/io/obj.rs"}
    assert folders == {"crates/mesh/src"}


def test_architecture_md_names_every_source_file_and_only_those() -> None:
    names, _ = named_files(DOC.read_text())
    files = source_files(ROOT)
    missing = sorted(files - names)
    stale = sorted(names - files)
    assert missing == [], f"source files ARCHITECTURE.md does not name: {missing}"
    assert stale == [], f"ARCHITECTURE.md names files that do not exist: {stale}"
