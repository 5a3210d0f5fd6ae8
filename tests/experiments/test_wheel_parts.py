"""A wheel larger than one transfer to a GPU machine travels in parts (experiments/wheel_parts.sh): split here,
joined there into the same bytes; a damaged part is an error, never an install of a broken wheel."""

import hashlib
import os
import subprocess
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "wheel_parts.sh"


def _run(*args) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(SCRIPT), *map(str, args)], capture_output=True, text=True)


def test_a_big_wheel_is_split_and_joined_into_the_same_bytes(tmp_path):
    big, small = tmp_path / "big-1.0-py3-none-any.whl", tmp_path / "small-1.0-py3-none-any.whl"
    big.write_bytes(os.urandom(2_500_000))
    small.write_bytes(os.urandom(1000))
    digest = hashlib.sha256(big.read_bytes()).hexdigest()
    assert _run("split", tmp_path, 1).returncode == 0
    parts = sorted((tmp_path / "parts").glob("big-1.0-py3-none-any.whl.part*"))
    assert not big.exists() and small.exists() and len(parts) == 3  # 2.5 MB in 1 MiB parts; the small one stays
    assert max(p.stat().st_size for p in parts) <= 1024 * 1024
    assert _run("join", tmp_path).returncode == 0
    assert hashlib.sha256(big.read_bytes()).hexdigest() == digest
    with parts[1].open("ab") as f:  # a part damaged in transit
        f.write(b"x")
    bad = _run("join", tmp_path)
    assert bad.returncode == 2 and "error: big-1.0-py3-none-any.whl" in bad.stderr and not big.exists()
