"""Special files and refused files, for every format and writer, Python's and
the core's: a FIFO or a device is never read as a mesh (a FIFO would wait for
a writer, /dev/zero never ends) and never replaced by a regular file (as root,
renamed over a device node, the node is gone); a character device and a pipe
with a reader are written straight into; what the system refuses is a
FileError, which is a SpherifyError and the builtin OSError of its cause."""

from __future__ import annotations

import os
import pickle
import socket
import stat
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from typing import Any, Callable, Dict, List

import numpy as np
import pytest

import spherify as sp

from _child import child_env

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs (POSIX)")


@pytest.fixture(scope="module")
def sphere_map() -> sp.SphereMap:
    return sp.embed(sp.datasets.icosphere(subdivisions=1), method="theta_phi")


def writers(m: sp.SphereMap) -> Dict[str, Callable[[Path], Any]]:
    """Every public writer, by the name its target must have."""
    return {
        "mesh.ply": lambda p: sp.save(m.mesh, p, sphere=m.points),
        "mesh.obj": lambda p: sp.save(m.mesh, p),
        "mesh.npz": lambda p: sp.save(m.mesh, p),
        "map.spheremap.npz": lambda p: m.save(p),
        "image.png": lambda p: sp.save_geometry_image(sp.geometry_image(m, 9), p),
        "texture.png": lambda p: sp.texture.write_png(np.zeros((4, 4, 3)), p),
    }


READERS: Dict[str, str] = {
    "mesh.ply": "sp.load(path)",
    "mesh.npz": "sp.load(path)",
    "lh.pial": "sp.load(path)",  # no extension: the first bytes are looked at
    "pair.npy": "sp.load((path, path))",
    "map.spheremap.npz": "sp.load_map(path)",
    "image.png": "sp.load_geometry_image(path)",
}


# --------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(READERS))
@pytest.mark.parametrize("special", ["fifo", "/dev/zero"])
def test_a_fifo_or_a_device_is_refused_at_once_by_every_reader(
        tmp_path: Path, name: str, special: str) -> None:
    """In a child with a deadline: before the fix the .npz reader read
    /dev/zero for ever and the nameless one waited on the FIFO."""
    path = tmp_path / name
    if special == "fifo":
        os.mkfifo(path)
    elif os.path.exists(special):
        path.symlink_to(special)
    else:
        pytest.skip(f"no {special}")
    script = f"""
        import spherify as sp
        path = {str(path)!r}
        try:
            {READERS[name]}
        except sp.FormatError as e:
            assert "not a regular file" in str(e) and str(e).startswith(path), e
            print("OK")
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True,
                          text=True, timeout=60, env=child_env())
    assert done.stdout.strip() == "OK", done.stderr


def test_a_file_larger_than_memory_is_an_error_not_an_abort(tmp_path: Path) -> None:
    """A 4 TB sparse .ply: the core used to abort the whole process (Rust's
    allocation failure) where it reserved the file's size. In a child, which
    such an abort would kill."""
    try:
        overcommit = Path("/proc/sys/vm/overcommit_memory").read_text().strip()
    except OSError:
        pytest.skip("needs Linux's /proc/sys/vm/overcommit_memory")
    if overcommit == "1":
        pytest.skip("the kernel grants any allocation here: the read would really start")
    path = tmp_path / "huge.ply"
    try:
        with open(path, "wb") as handle:
            handle.truncate(4 << 40)
    except OSError:
        pytest.skip("the file system holds no 4 TB sparse file")
    script = f"""
        import spherify as sp
        try:
            sp.load({str(path)!r})
        except sp.FileError as e:
            assert "more than this process can hold in memory" in str(e), e
            print("OK")
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True,
                          text=True, timeout=60, env=child_env())
    assert done.stdout.strip() == "OK", (done.returncode, done.stderr[-2000:])


# --------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------

def _drain(fifo: Path, into: List[bytes]) -> threading.Thread:
    thread = threading.Thread(target=lambda: into.append(fifo.read_bytes()), daemon=True)
    thread.start()
    return thread


def _unblock(fifo: Path) -> None:
    """Opens ``fifo`` for writing, non-blocking, and closes it: a reader
    waiting in its open then reads end-of-file, so a failed test ends."""
    try:
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    except OSError:
        pass


@pytest.mark.parametrize("name", ["mesh.ply", "mesh.obj", "mesh.npz", "map.spheremap.npz",
                                  "image.png", "texture.png"])
def test_a_pipe_with_a_reader_gets_the_bytes_and_stays_a_pipe(
        tmp_path: Path, sphere_map: sp.SphereMap, name: str) -> None:
    write = writers(sphere_map)[name]
    regular = tmp_path / f"regular-{name}"
    write(regular)
    fifo = tmp_path / name
    os.mkfifo(fifo)
    received: List[bytes] = []
    reader = _drain(fifo, received)
    deadline = time.monotonic() + 20
    while True:  # until the reader's open has happened
        try:
            write(fifo)
            break
        except sp.FormatError as e:
            assert "no process is reading" in str(e), e
            assert time.monotonic() < deadline, "the reader never opened the pipe"
            time.sleep(0.01)
    is_fifo = stat.S_ISFIFO(os.stat(fifo).st_mode)
    if not is_fifo:
        _unblock(fifo)
    reader.join(20)
    assert is_fifo, "the pipe was replaced by a regular file"
    assert received and received[0] == regular.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, regular.name])


@pytest.mark.parametrize("name", ["mesh.ply", "mesh.npz", "map.spheremap.npz", "image.png"])
def test_a_pipe_nobody_reads_is_refused_at_once(
        tmp_path: Path, sphere_map: sp.SphereMap, name: str) -> None:
    fifo = tmp_path / name
    os.mkfifo(fifo)
    # A writer that waited for a reader would hang the test: this one opens
    # the pipe for reading after 10 s, which ends such a wait.
    late = threading.Timer(10, lambda: os.close(os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)))
    late.start()
    try:
        start = time.monotonic()
        with pytest.raises(sp.FormatError, match="no process is reading"):
            writers(sphere_map)[name](fifo)
        assert time.monotonic() - start < 5
    finally:
        late.cancel()
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == [name]


def _null_device(folder: Path) -> Path:
    """A character device like /dev/null inside ``folder`` (mknod needs
    root): a test that went wrong replaces this node, not the machine's."""
    node = folder / "null-device"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, AttributeError, OSError):
        pytest.skip("cannot make a device node here (needs root)")
    return node


@pytest.mark.parametrize("name", ["mesh.ply", "mesh.npz", "map.spheremap.npz", "image.png",
                                  "texture.png"])
def test_a_character_device_is_written_into_not_replaced(
        tmp_path: Path, sphere_map: sp.SphereMap, name: str) -> None:
    device = _null_device(tmp_path)
    link = tmp_path / name  # the writers choose the format by the name
    link.symlink_to(device)
    writers(sphere_map)[name](link)
    assert stat.S_ISCHR(os.stat(device).st_mode) and link.is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "null-device"])


@pytest.mark.parametrize("name", ["mesh.ply", "mesh.npz"])
def test_a_socket_is_refused(tmp_path: Path, sphere_map: sp.SphereMap, name: str) -> None:
    path = tmp_path / name
    server = socket.socket(socket.AF_UNIX)
    try:
        server.bind(str(path))
        with pytest.raises(sp.FormatError, match="a socket"):
            writers(sphere_map)[name](path)
        assert stat.S_ISSOCK(os.stat(path).st_mode)
    finally:
        server.close()


@pytest.mark.parametrize("name", ["mesh.ply", "mesh.npz", "map.spheremap.npz"])
def test_python_writers_follow_links_and_keep_the_mode_as_the_core_does(
        tmp_path: Path, sphere_map: sp.SphereMap, name: str) -> None:
    real = tmp_path / f"real-{name}"
    real.write_bytes(b"old")
    real.chmod(0o600)
    link = tmp_path / name
    link.symlink_to(real.name)
    writers(sphere_map)[name](link)
    assert link.is_symlink() and real.read_bytes() != b"old"
    assert stat.S_IMODE(os.stat(real).st_mode) == 0o600


# --------------------------------------------------------------------------
# FileError
# --------------------------------------------------------------------------

@pytest.mark.parametrize("call, builtin", [
    (lambda d: sp.load(d / "missing.ply"), FileNotFoundError),
    (lambda d: sp.load(d / "missing.npz"), FileNotFoundError),
    (lambda d: sp.load_map(d / "missing.spheremap.npz"), FileNotFoundError),
    (lambda d: sp.load_geometry_image(d / "missing.png"), FileNotFoundError),
    (lambda d: sp.load(d), IsADirectoryError),
    (lambda d: sp.save(sp.datasets.icosphere(subdivisions=0), d / "no" / "t.ply"), FileNotFoundError),
    (lambda d: sp.save(sp.datasets.icosphere(subdivisions=0), d / "no" / "t.npz"), FileNotFoundError),
])
def test_what_the_system_refuses_is_a_file_error_and_its_builtin(
        tmp_path: Path, call: Callable[[Path], Any], builtin: type) -> None:
    with pytest.raises(sp.FileError) as info:
        call(tmp_path)
    err = info.value
    assert isinstance(err, builtin) and isinstance(err, sp.SpherifyError)
    assert err.errno is not None and str(tmp_path) in str(err.filename)
    assert ".tmp-" not in str(err)  # names what the caller asked for
    again = pickle.loads(pickle.dumps(err))  # batch workers send errors across
    assert type(again) is type(err) and again.filename == err.filename


def test_a_folder_in_place_of_an_output_is_refused_before_writing(
        tmp_path: Path, sphere_map: sp.SphereMap) -> None:
    for name in ["mesh.ply", "mesh.npz", "map.spheremap.npz"]:
        folder = tmp_path / name
        folder.mkdir()
        with pytest.raises(IsADirectoryError) as info:
            writers(sphere_map)[name](folder)
        assert isinstance(info.value, sp.FileError)
        assert list(folder.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.spheremap.npz", "mesh.npz",
                                                           "mesh.ply"]
