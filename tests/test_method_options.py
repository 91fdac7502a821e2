"""The core's one table of method options (crates/sphere/src/method_options.rs)
is the only list: sp.embed, sp.batch and the command line read it, and no
second list of option names may appear in the package (issue 25, item 1)."""

from __future__ import annotations

import ast
import warnings
from pathlib import Path
from typing import List, Set

import pytest

import spherify as sp
from spherify import cli

PACKAGE = Path(sp.__file__).parent


def _all_option_names() -> Set[str]:
    return {name for method in sp.methods() + ["improve"] for name in sp.method_options(method)}


def _second_lists(source: str) -> List[str]:
    """Literal lists, tuples, sets and dict keys that hold two or more
    strings, all of them option names: a second list of options."""
    names = _all_option_names()
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            items = node.elts
        elif isinstance(node, ast.Dict):
            items = [k for k in node.keys if k is not None]
        else:
            continue
        strings = [i.value for i in items if isinstance(i, ast.Constant) and isinstance(i.value, str)]
        if len(strings) >= 2 and len(strings) == len(items) and set(strings) <= names:
            found.append(f"line {node.lineno}: {strings}")
    return found


def test_the_scan_finds_a_second_list() -> None:
    # The test below must be able to fail.
    assert _second_lists('THETA_PHI = ("poles", "weights", "rho")\n')
    assert _second_lists('X = {"poles": ("theta_phi", None), "energy": 1}\n')
    assert not _second_lists('X = ("poles", "mesh")\n')


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: p.name)
def test_no_module_keeps_a_second_list_of_options(path: Path) -> None:
    assert _second_lists(path.read_text()) == [], path


def test_the_command_line_has_a_flag_for_every_option_of_the_table() -> None:
    parser_flags = set()
    for method in sp.methods():
        for name, row in sp.method_options(method).items():
            if row["kind"] != "points":
                parser_flags.add("--" + name.replace("_", "-"))
    help_text = cli_help("map")
    missing = [flag for flag in sorted(parser_flags) if flag not in help_text]
    assert missing == []


def cli_help(command: str) -> str:
    import contextlib
    import io
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        cli.main([command, "--help"])
    return out.getvalue()


def test_a_batch_takes_what_its_method_takes(tmp_path: Path) -> None:
    # Issue 25: sp.batch(method="relaxation", weights="chord") was refused,
    # because the batch's own list called weights theta-phi's only.
    folder = tmp_path / "in"
    folder.mkdir()
    sp.save(sp.datasets.make("icosphere", 42), folder / "ball.ply")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sp.SpherifyWarning)
        result = sp.batch(folder, tmp_path / "out", method="relaxation", weights="chord",
                          workers=1)
    (row,) = result.rows
    assert row["method"] == "relaxation" and row["status"] == "done", row
    direct = sp.embed(sp.load(folder / "ball.ply"), "relaxation", weights="chord")
    assert row["valid"] == direct.valid


def test_unknown_method_is_a_mesh_error() -> None:
    with pytest.raises(sp.MeshError, match="unknown method 'nope'"):
        sp.method_options("nope")
