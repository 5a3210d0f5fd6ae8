"""The run folder: its layout is RunDir's alone; evaluations are keyed by checkpoint and protocol (one never
overwrites another's); and a damaged folder (mutated record, missing or truncated checkpoint items) loads or is one
error line, never a traceback (a seeded fuzz)."""

import dataclasses
import json
import random
import shutil

import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.runs.commands import evaluate_checkpoint, load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from tests.conftest import TINY_RUNS, tiny_spec

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # its trained run is built once, beside the others


@pytest.fixture(scope="session")
def run(tmp_path_factory):
    r = RunDir(tmp_path_factory.mktemp("rundir") / "run")
    start_or_resume(tiny_spec(schedule={"save_every": 1, "robust_every": 0}), [r], resume=False, progress=False)
    return r


def test_the_layout(run):
    assert run.exists() and run.trajectory_path.is_file() and run.tensorboard.is_dir()
    assert sorted(run.epoch_checkpoints()) == [1, 2] and run.has_checkpoint("final")
    assert run.policy_checkpoint().name == "final"  # no robustness selection: the final checkpoint
    assert run.trained_epochs() == 2 and [r["epoch"] for r in run.log_rows()] == [1, 2]
    other, ck = RunDir.of_checkpoint(run.checkpoint("epoch_0001"))
    assert other.path == run.path and ck.name == "epoch_0001"
    with pytest.raises(DragMeshError, match="no such checkpoint"):
        RunDir.of_checkpoint(run.path / "checkpoints" / "nope")
    with pytest.raises(DragMeshError, match="already holds a run"):
        start_or_resume(tiny_spec(), [run], resume=False, progress=False)


def test_a_run_started_again_replaces_its_own_files_and_keeps_what_the_command_built_beside_them(run, tmp_path):
    """A run that stopped before its first checkpoint starts again; what was built into its folder before the run
    started (the generalist's objects) stays."""
    folder = tmp_path / "again"
    shutil.copytree(run.path, folder, ignore=shutil.ignore_patterns("checkpoints"))
    (folder / "objects").mkdir()
    (folder / "objects" / "part.obj").write_text("v 0 0 0\n")
    again = RunDir(folder)
    again.start(run.spec(), run.backend, run.trajectory())
    assert (folder / "objects" / "part.obj").read_text() == "v 0 0 0\n"
    assert again.exists() and not again.log_rows() and not again.tensorboard.exists()


def test_evaluations_are_kept_by_checkpoint_and_protocol(run):
    tiny = dataclasses.replace(PAPER, episodes=2, modes=("det",))
    x8 = dataclasses.replace(tiny, dampings=(4.0, 8.0))
    first, p1 = evaluate_checkpoint(str(run.path), tiny)
    second, p2 = evaluate_checkpoint(str(run.path), x8)
    third, p3 = evaluate_checkpoint(str(run.checkpoint("epoch_0001")), tiny)
    assert len({p1, p2, p3}) == 3 and all(p.is_file() for p in (p1, p2, p3))  # nothing overwritten
    assert run.evaluation(run.policy_checkpoint(), tiny) == json.loads(p1.read_text())
    assert [c["damping"] for c in run.evaluation(run.policy_checkpoint(), x8)["cells"]] == [4.0, 8.0]
    assert p1.with_suffix(".md").is_file()


def _mutations(rng: random.Random, text: str):
    """Mutated copies of a JSON text: truncated, emptied, a line deleted or duplicated, a number swapped for an
    extreme, a key dropped."""
    lines = text.splitlines()
    i = rng.randrange(len(lines))
    yield "truncated", text[: rng.randrange(len(text))]
    yield "emptied", ""
    yield "line deleted", "\n".join(lines[:i] + lines[i + 1:])
    yield "line duplicated", "\n".join(lines[: i + 1] + lines[i:])
    for bad in ("0", "1e9", "Infinity", "NaN", "-1"):
        numbers = [k for k, line in enumerate(lines) if any(ch.isdigit() for ch in line.split(":")[-1])]
        k = rng.choice(numbers)
        key, _, value = lines[k].partition(":")
        yield f"number -> {bad}", "\n".join(lines[:k] + [f"{key}: {bad}{',' if value.rstrip().endswith(',') else ''}"]
                                            + lines[k + 1:])
    record = json.loads(text)
    for key in rng.sample(sorted(record), 3):
        yield f"dropped {key}", json.dumps({k: v for k, v in record.items() if k != key}, indent=1)


def _loads_or_one_line(path, what: str):
    try:
        load_run(path)
    except DragMeshError as e:
        assert "\n" not in str(e), what


def test_a_damaged_run_folder_loads_or_is_one_error_line(run, tmp_path):
    rng = random.Random(0)
    text = json.dumps(run.record(), indent=1)
    cases = list(_mutations(rng, text))
    for k, (what, mutated) in enumerate(cases):
        copy = tmp_path / f"record_{k}"
        shutil.copytree(run.path, copy)
        (copy / "run.json").write_text(mutated)
        _loads_or_one_line(copy, what)
    items = [p for p in (run.checkpoint("final")).rglob("*") if p.is_file()]
    for k, victim in enumerate(rng.sample(items, min(6, len(items)))):
        copy = tmp_path / f"checkpoint_{k}"
        shutil.copytree(run.path, copy)
        target = copy / victim.relative_to(run.path)
        data = target.read_bytes()
        target.write_bytes(data[: len(data) // 2])  # truncated
        _loads_or_one_line(copy / "checkpoints" / "final", f"truncated {victim.name}")
    for item in ("learner", "env"):
        copy = tmp_path / f"missing_{item}"
        shutil.copytree(run.path, copy)
        shutil.rmtree(copy / "checkpoints" / "final" / item)
        _loads_or_one_line(copy / "checkpoints" / "final", f"no {item}")
    assert len(cases) >= 10
