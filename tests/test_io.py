"""Folders one writer at a time may change, and operating-system faults as one line."""

import errno
import subprocess
import sys
import textwrap

import pytest

from dragmesh2_jax.errors import FolderBusy, NotWritable
from dragmesh2_jax.io import LOCK_NAME, atomic_write_text, folder_lock, make_folder, os_error_line
from tests.conftest import read_only


def hold_lock(folder) -> subprocess.Popen:
    """Another process holding ``folder``'s lock until its standard input closes; returns once it holds it."""
    code = textwrap.dedent(f"""
        import sys
        from dragmesh2_jax.io import folder_lock
        with folder_lock({str(folder)!r}):
            print("held", flush=True)
            sys.stdin.read()
    """)
    holder = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              text=True)
    assert holder.stdout.readline().strip() == "held"
    return holder


def release(holder: subprocess.Popen) -> None:
    holder.stdin.close()
    assert holder.wait(timeout=60) == 0


def test_a_second_process_is_refused_with_the_holders_process_id(tmp_path):
    holder = hold_lock(tmp_path / "run")
    try:
        with pytest.raises(FolderBusy, match=f"in use by another writer \\(process {holder.pid}: "), \
                folder_lock(tmp_path / "run"):
            pass
    finally:
        release(holder)
    with folder_lock(tmp_path / "run"):  # free once the holder ended
        assert (tmp_path / "run" / LOCK_NAME).is_file()


def test_the_lock_goes_with_its_process_however_it_ends(tmp_path):
    holder = hold_lock(tmp_path)
    holder.kill()
    holder.wait(timeout=60)
    with folder_lock(tmp_path):
        pass


def test_the_holding_process_may_enter_again(tmp_path):
    with folder_lock(tmp_path), folder_lock(tmp_path / "."):
        pass
    with folder_lock(tmp_path):  # and released when the outer block ends
        pass


def test_a_folder_that_cannot_be_made_or_written_is_one_line(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(Exception, match="exists and is not a folder"):
        make_folder(tmp_path / "file")
    with pytest.raises(Exception, match="cannot be created \\(Not a directory\\)"):
        make_folder(tmp_path / "file" / "sub")
    with read_only(tmp_path / "ro"), pytest.raises(NotWritable, match="cannot be written"), \
            folder_lock(tmp_path / "ro"):
        pass


def test_an_interrupted_atomic_write_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    path = atomic_write_text(tmp_path / "a.json", "old")

    def full(fd):  # where a full disk shows on a buffered write
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr("os.fsync", full)
    with pytest.raises(OSError):
        atomic_write_text(path, "new" * 1000)
    monkeypatch.undo()
    assert path.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_an_operating_system_fault_reads_as_one_line_with_what_to_do():
    line = os_error_line(OSError(errno.ENOSPC, "No space left on device", "/runs/x/log.jsonl"))
    assert line.startswith("/runs/x/log.jsonl: No space left on device; free some space") and "\n" not in line
    assert "read-only" in os_error_line(OSError(errno.EROFS, "Read-only file system", "/x"))
