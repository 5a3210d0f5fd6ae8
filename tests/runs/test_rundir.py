"""The run folder: its layout is RunDir's alone; evaluations are keyed by checkpoint and protocol (one never
overwrites another's); and a damaged folder (mutated record, missing or truncated checkpoint items) loads or is one
error line, never a traceback (a seeded fuzz)."""

import dataclasses
import json
import random
import shutil

import jax
import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.runs.commands import evaluate_checkpoint, load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import SECTIONS
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
    # a zero-shot evaluation is kept beside them by the object's name, a folder given for it named by its last part
    elsewhere = run.evaluation_path(run.policy_checkpoint(), tiny, on="/objects/shared/45780")
    assert elsewhere.parent == p1.parent and elsewhere.name.endswith("__on-45780.json")


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


def _loads_or_one_line(load, what: str):
    """What ``load()`` returns, or None where it raised an error of one line."""
    try:
        return load()
    except DragMeshError as e:
        assert "\n" not in str(e), what
        return None


def _load_whole(checkpoint):
    """The train state of a checkpoint (or of a run folder's), its worlds too: what an exact resume restores."""
    return load_run(checkpoint, keep_env=False)[1]


def _same(a, b, what: str) -> None:
    assert jax.tree.structure(a) == jax.tree.structure(b), what
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y), err_msg=what)


def _loads_the_saved_or_one_line(checkpoint, saved, what: str) -> None:
    got = _loads_or_one_line(lambda: _load_whole(checkpoint), what)
    if got is not None:
        _same(got, saved, what)


def _said(record: dict) -> dict:
    """What a record states: a key it holds as an empty list or null states what its absence does."""
    return {k: v for k, v in record.items() if v not in ([], None)}


def test_a_record_whose_network_lost_a_layer_is_one_error_line_not_the_checkpoints_first_layers(run, tmp_path):
    """flax restores the keys a template has and drops the rest: a record stating one hidden layer fewer than its
    checkpoint holds must not load that checkpoint's first layers as a smaller network."""
    copy = tmp_path / "one_layer"
    shutil.copytree(run.path, copy)
    record = run.record()
    assert len(record["network"]["state_sizes"]) > 1
    record["network"]["state_sizes"] = record["network"]["state_sizes"][:1]
    (copy / "run.json").write_text(json.dumps(record, indent=1))
    with pytest.raises(DragMeshError, match="which the program does not") as e:
        load_run(copy, keep_env=False)
    assert "\n" not in str(e.value)


def test_a_damaged_run_folder_loads_or_is_one_error_line(run, tmp_path):
    """Each damage is one error line or loads what the folder held, read whole (the learner and the worlds, as an
    exact resume reads them). A mutated record loads the checkpoint's values and its config as the record now states
    it (the original's where it states the same). A checkpoint with one of its files truncated (six drawn, or each
    where it has fewer) or one of its items missing loads the very values saved. A loader that handed back a
    template's values, or garbage, fails."""
    saved, record, rng = _load_whole(run.path), run.record(), random.Random(0)
    cases = list(_mutations(rng, json.dumps(record, indent=1)))
    assert len(cases) == 12  # truncated, emptied, a line deleted, one duplicated, five numbers, three keys dropped
    loaded = []
    for k, (what, mutated) in enumerate(cases):
        copy = tmp_path / f"record_{k}"
        shutil.copytree(run.path, copy)
        (copy / "run.json").write_text(mutated)
        got = _loads_or_one_line(lambda copy=copy: load_run(copy, keep_env=False), what)
        if got is None:
            continue
        loaded.append(what)
        _, ts, again, _ = got
        _same(ts, saved, what)  # the checkpoint's values, whatever the record says
        stated, spec = json.loads(mutated), json.loads(json.dumps(again.spec().sections()))
        held = [section for section in SECTIONS if section in stated]
        assert {x: spec[x] for x in held} == {x: stated[x] for x in held}, what  # each section as it now reads
        if _said(stated) == _said(record):  # it states what the original did
            assert again.spec() == run.spec(), what
    assert loaded and len(loaded) < len(cases), loaded  # the fuzz meets both outcomes: neither check stands idle
    final = run.checkpoint("final")
    files = sorted(p.relative_to(run.path) for p in final.rglob("*") if p.is_file())
    for k, name in enumerate(rng.sample(files, min(6, len(files)))):
        copy = tmp_path / f"truncated_{k}"
        shutil.copytree(run.path, copy)
        data = (copy / name).read_bytes()
        (copy / name).write_bytes(data[: len(data) // 2])
        _loads_the_saved_or_one_line(copy / "checkpoints" / "final", saved, f"truncated {name}")
    items = sorted(p.name for p in final.iterdir())
    for item in items:
        copy = tmp_path / f"missing_{item}"
        shutil.copytree(run.path, copy)
        missing = copy / "checkpoints" / "final" / item
        if missing.is_dir():
            shutil.rmtree(missing)
        else:
            missing.unlink()
        _loads_the_saved_or_one_line(copy / "checkpoints" / "final", saved, f"no {item}")
    assert len(items) == 2 and len(files) >= 2  # the learner's and the worlds' items, each one or more files
