"""Outputs are written atomically (complete or absent) and output locations are checked before any work."""

from __future__ import annotations

import errno
import os

import pytest

from foam_mj import atomic
from foam_mj.atomic import OutputError, atomic_path, atomic_write_text, check_output, check_output_dir


def test_a_complete_write_renames_into_place_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "out.json"
    target.write_text("old")
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".json" and tmp.name.startswith(".")
        tmp.write_text("new")
        assert target.read_text() == "old"  # the old file stays until the rename
    assert target.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_a_failed_write_leaves_neither_file_nor_temporary(tmp_path):
    target = tmp_path / "out.json"
    with pytest.raises(OutputError, match=r"could not write .*out.json: No space left on device"):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise KeyboardInterrupt
    with pytest.raises(OutputError, match="produced no file"):
        with atomic_path(target):
            pass
    assert list(tmp_path.iterdir()) == []


def test_an_existing_file_survives_a_failed_write(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("complete")
    with pytest.raises(ValueError):
        with atomic_path(target) as tmp:
            tmp.write_text("partial")
            raise ValueError("writer failed")
    assert target.read_text() == "complete" and [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: "", "empty file name"),
        (lambda d: d / "missing" / "x.json", "does not exist"),
        (lambda d: d, "is a directory"),
        (lambda d: d / ("a" * 300 + ".json"), "longer than this file system allows"),
        (lambda d: "/proc/x.json", "cannot create a file in /proc"),
        (lambda d: d / "x.txt", "must end in .rrd"),
        (lambda d: d / ".rrd", r"is only the suffix \.rrd: give a name before it \(out\.rrd\)"),  # was 'must end in .rrd'
    ],
)
def test_check_output_refuses_what_cannot_be_written(tmp_path, make, message):
    with pytest.raises(OutputError, match=message):
        check_output(make(tmp_path), "--out", suffix=".rrd" if ".rrd" in message else None)
    assert list(tmp_path.iterdir()) == []  # the probe leaves nothing behind


def test_check_output_refuses_a_full_file_system(tmp_path, monkeypatch):
    free = os.statvfs(tmp_path).f_bavail * os.statvfs(tmp_path).f_frsize
    monkeypatch.setattr(atomic, "MIN_FREE_BYTES", free + (1 << 40))
    with pytest.raises(OutputError, match="no space left"):
        check_output(tmp_path / "x.json", "--json")
    assert check_output(tmp_path / "x.json", "--json", min_free=0) == tmp_path / "x.json"


def test_check_output_dir_accepts_a_creatable_folder_only(tmp_path):
    assert check_output_dir(tmp_path / "new", "--figures") == tmp_path / "new"
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="is a file"):
        check_output_dir(tmp_path / "file", "--figures")
    with pytest.raises(OutputError, match="does not exist"):
        check_output_dir(tmp_path / "a" / "b", "--figures")


def test_check_output_dir_names_the_folder_given_not_a_probe_file(tmp_path, monkeypatch):
    """`sweep --out /ro/study` said "--out output /ro/x: cannot create a file in /ro": a file "x" nobody named."""
    for given, folder in (("/proc/study", "/proc"), ("/proc", "/proc")):
        with pytest.raises(OutputError) as exc:
            check_output_dir(given, "--out")
        assert str(exc.value).startswith(f"--out {given}: cannot create a file in {folder}: "), exc.value
    monkeypatch.setattr(atomic, "MIN_FREE_BYTES", (1 << 62))
    with pytest.raises(OutputError, match=rf"^--figures {tmp_path}/figs: no space left on its file system \("):
        check_output_dir(tmp_path / "figs", "--figures")


def test_atomic_write_text_is_complete(tmp_path):
    p = atomic_write_text(tmp_path / "t.txt", "é" * 1000)
    assert p.read_text(encoding="utf-8") == "é" * 1000


def test_an_output_that_is_not_a_regular_file_is_refused_and_left_alone(tmp_path):
    # The final rename would replace the node itself: `plan --json /dev/null` as root turned /dev/null into a
    # regular file. A device, FIFO or socket is refused before any work, and atomic_path never renames onto one.
    with pytest.raises(OutputError, match=r"/dev/null exists and is not a regular file \(a character device\)"):
        check_output("/dev/null", "--json")
    assert os.path.exists("/dev/null") and not os.path.isfile("/dev/null")
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    with pytest.raises(OutputError, match="is not a regular file \\(a FIFO\\)"):
        check_output(fifo, "--json")
    with pytest.raises(OutputError, match="is not a regular file \\(a FIFO\\)"):
        atomic_write_text(fifo, "{}")
    assert fifo.is_fifo() and [p.name for p in tmp_path.iterdir()] == ["pipe.json"]


def test_an_output_name_ending_in_a_slash_is_a_folder_not_a_file(tmp_path):
    # `--json out/` used to write a file named `out`.
    with pytest.raises(OutputError, match="ends in '/': it names a folder"):
        check_output(f"{tmp_path}/new/", "--json")
    assert list(tmp_path.iterdir()) == []


def test_a_symbolic_link_is_kept_and_the_file_it_points_to_is_replaced(tmp_path):
    # `export --out /dev/stdout` (stdout redirected to a file) as root renamed the export onto the /dev/stdout link
    # itself: the machine's /dev/stdout became a regular file. A link is checked and written as the file it names.
    real, link = tmp_path / "real.csv", tmp_path / "link.csv"
    real.write_text("old")
    link.symlink_to(real)
    assert check_output(link, "--out") == link
    atomic_write_text(link, "new")
    assert link.is_symlink() and os.readlink(link) == str(real) and real.read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "real.csv"]


def test_a_link_to_a_device_or_to_nowhere_is_refused_and_left_alone(tmp_path):
    device, dangling = tmp_path / "null.json", tmp_path / "dangling.json"
    device.symlink_to("/dev/null")
    dangling.symlink_to(tmp_path / "missing" / "x.json")
    with pytest.raises(OutputError, match=r"null.json \(a link to /dev/null\) exists and is not a regular file \(a character device\)"):
        check_output(device, "--json")
    with pytest.raises(OutputError, match=r"not a regular file"):
        atomic_write_text(device, "{}")
    with pytest.raises(OutputError, match=r"dangling.json \(a link to .*missing/x.json\): folder .*missing does not exist"):
        check_output(dangling, "--json")
    assert device.is_symlink() and dangling.is_symlink() and os.path.exists("/dev/null") and not os.path.isfile("/dev/null")
