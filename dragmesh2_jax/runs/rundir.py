"""The run folder, and the only code that knows its layout:

    run.json                 the run record (``runs/spec.py``), written once when the run starts
    trajectory.json          the reference trajectory the task was built from
    log.jsonl, log.csv       one row per epoch: every metric the epoch returned
    robust.jsonl, robust.csv the robustness checks that select ``best_robust`` (paper App. B.3-B.4)
    tb/                      the same scalars as TensorBoard event files
    checkpoints/NAME         checkpoints (``ppo/checkpoint.py``): ``epoch_NNNN``, ``best`` (training
                             reward), ``best_robust``, ``final``
    actor.msgpack            the policy exported alone (``ppo/checkpoint.save_actor``): what a packaged run ships
    evaluations/CK__PROTOCOL.json, .md   an evaluation of checkpoint CK under a protocol (``EvalProtocol.name``):
                             one never overwrites another's

    .lock                    the operating system's advisory lock of the process writing the run (train,
                             finetune, evaluate, reproduce, the demo): one writer at a time

Tables are rewritten whole and atomically at every row (a crash leaves the previous version). A run's products
(checkpoints, evaluations, the exported actor) are never removed but by ``--overwrite`` (``RunDir.clear``): a new run
in a folder that holds them is refused (``RunDir.require_new``).

A packaged run (``PACKAGED``: the generalist that ships with the package) is such a folder with its record and its
exported actor only, read where a checkpoint is taken by its name (``--checkpoint generalist``), never written.
"""

from __future__ import annotations

import contextlib
import copy
import csv
import io
import json
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.io import aside, atomic_write_json, atomic_write_text, folder_lock, restore_aside
from dragmesh2_jax.ppo.checkpoint import ACTOR_SUFFIX, is_checkpoint
from dragmesh2_jax.runs.spec import RECORD_FORMAT, RunSpec
from dragmesh2_jax.trajectory.schema import Trajectory, read_trajectory, write_trajectory

#: Checkpoints a run offers as its policy, in the order they are preferred.
CHECKPOINT_PREFERENCE = ("best_robust", "final")
EPOCH_PREFIX = "epoch_"
ACTOR_NAME = "actor" + ACTOR_SUFFIX
#: Runs that ship with the package, by the name a checkpoint flag takes.
PACKAGED = {"generalist": Path(__file__).resolve().parent.parent / "data" / "generalist"}
#: The layout's names (the module docstring).
RECORD, TRAJECTORY, OBJECT_TRAJECTORIES, TENSORBOARD = "run.json", "trajectory.json", "trajectories", "tb"
CHECKPOINTS, EVALUATIONS, TABLES, ROWS, CSV = "checkpoints", "evaluations", ("log", "robust"), ".jsonl", ".csv"
#: What a run writes into its folder; a new run replaces these and nothing else, so what the command built into the
#: folder before the run started (the generalist's objects) stays.
RUN_PRODUCTS = (RECORD, TRAJECTORY, OBJECT_TRAJECTORIES, TENSORBOARD, CHECKPOINTS, EVALUATIONS, ACTOR_NAME,
                *(t + x for t in TABLES for x in (ROWS, CSV)))


def epoch_name(epoch: int) -> str:
    return f"{EPOCH_PREFIX}{epoch:04d}"


class RunDir:
    """A run folder (see the module docstring); nothing is read or written before it is asked for."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._record: dict | None = None

    def __repr__(self) -> str:
        return f"RunDir({str(self.path)!r})"

    @property
    def record_path(self) -> Path:
        return self.path / RECORD

    @property
    def trajectory_path(self) -> Path:
        return self.path / TRAJECTORY

    @property
    def tensorboard(self) -> Path:
        return self.path / TENSORBOARD

    def exists(self) -> bool:
        """Whether the folder holds a run (its record)."""
        return self.record_path.is_file()

    def products(self) -> list[str]:
        """What the folder holds that a run made and a user keeps (checkpoints, evaluations, the exported actor), by
        name relative to the folder."""
        held = [f"{CHECKPOINTS}/{p.name}" for p in sorted((self.path / CHECKPOINTS).glob("*")) if is_checkpoint(p)]
        held += [f"{EVALUATIONS}/{p.name}" for p in sorted((self.path / EVALUATIONS).glob("*.json"))]
        return held + ([ACTOR_NAME] if self.actor_path.is_file() else [])

    def require_new(self) -> None:
        """A new run goes to a folder that holds no run's products: one error line otherwise, naming what it holds (a
        run that stopped before its first checkpoint starts again)."""
        held = self.products()
        if held:
            more = f" and {len(held) - 3} more" if len(held) > 3 else ""
            resume = ("--resume continues it, " if self.epoch_checkpoints() else
                      "with no epoch checkpoint to resume from, ")
            raise DragMeshError(f"{self.path}: already holds a run's products ({', '.join(held[:3])}{more}): "
                                f"{resume}--overwrite removes them and starts again, or give another --out")

    def clear(self) -> list[str]:
        """Remove what a run wrote into the folder (``RUN_PRODUCTS``; the rest of the folder stays): what
        ``--overwrite`` does before a new run. Returns the names removed."""
        removed = []
        for p in (self.path / name for name in RUN_PRODUCTS):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            elif p.exists() or p.is_symlink():
                p.unlink()
            else:
                continue
            removed.append(p.name)
        self._record = None
        return removed

    def restore_interrupted(self) -> list[str]:
        """Under the writer's lock, before anything is written: each checkpoint whose replacement a kill interrupted
        is put back whole and what the kill left is removed (``io.restore_aside``). Returns what was done."""
        folder = self.path / CHECKPOINTS
        return restore_aside(folder) if folder.is_dir() else []

    @contextlib.contextmanager
    def writing(self) -> Iterator[RunDir]:
        """Hold the run folder's lock (created where missing) for the block: a second writer, in another process,
        gets one error line naming this one's process id."""
        with folder_lock(self.path):
            yield self

    # ----------------------------------------------------------------------------------- the record
    def start(self, spec: RunSpec, backend: str, trajectory: Trajectory | list[Trajectory],
              buffers: dict | None = None) -> None:
        """Write the record and the trajectory of a new run (a run over several objects: one per object, in the
        spec's order) once (``require_new``): what a run that stopped before its first checkpoint left is replaced
        (``RUN_PRODUCTS``; the rest of the folder stays)."""
        self.require_new()
        if self.exists():
            self.clear()
        self.path.mkdir(parents=True, exist_ok=True)
        trajectories = trajectory if isinstance(trajectory, list) else [trajectory]
        write_trajectory(trajectories[0], self.trajectory_path)
        for i, t in enumerate(trajectories[1:], 1):
            write_trajectory(t, self._object_trajectory_path(i))
        atomic_write_json(self.record_path, spec.record(backend, buffers))
        self._record = None

    def record(self) -> dict:
        """The record as written, read once (each caller gets its own copy: the one kept is never changed)."""
        if self._record is None:
            if not self.exists():
                raise DragMeshError(f"{self.path}: not a training run folder (no run.json)")
            try:
                self._record = json.loads(self.record_path.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as e:
                raise DragMeshError(f"{self.record_path}: not valid JSON ({e})") from None
            if not isinstance(self._record, dict):
                raise DragMeshError(f"{self.record_path}: not a JSON object")
        return copy.deepcopy(self._record)

    def spec(self) -> RunSpec:
        return RunSpec.from_record(self.record(), where=str(self.record_path))

    def revise(self, spec: RunSpec) -> None:
        """A resume that trains further, saves and checks otherwise or sizes its buffers otherwise: the record's
        sections become ``spec``'s (``runs/session.py`` says what a resume may change), rewritten whole and
        atomically in the current format (a record of an earlier one upgraded as it reads); the rest of the record
        stands."""
        atomic_write_json(self.record_path, {**self.record(), "format": RECORD_FORMAT, **spec.sections()})
        self._record = None

    @property
    def backend(self) -> str:
        """The engine the run trained on."""
        b = self.record().get("backend")
        if not isinstance(b, str):
            raise DragMeshError(f"{self.record_path}: no engine recorded (backend)")
        return b

    def trajectory(self) -> Trajectory:
        return read_trajectory(self.trajectory_path)

    def _object_trajectory_path(self, index: int) -> Path:
        return self.path / OBJECT_TRAJECTORIES / f"object_{index:03d}.json"

    def trajectories(self) -> list[Trajectory]:
        """Every object's trajectory, in the spec's order (one for a single-object run)."""
        n = max(len(self.spec().objects), 1)
        return [self.trajectory(), *(read_trajectory(self._object_trajectory_path(i)) for i in range(1, n))]

    # -------------------------------------------------------------------------------- checkpoints
    def checkpoint(self, name: str) -> Path:
        return self.path / CHECKPOINTS / name

    def has_checkpoint(self, name: str) -> bool:
        return is_checkpoint(self.checkpoint(name))

    def epoch_checkpoints(self) -> dict[int, Path]:
        """The ``epoch_NNNN`` checkpoints by epoch."""
        out = {}
        for p in (self.path / CHECKPOINTS).glob(f"{EPOCH_PREFIX}*"):
            tail = p.name[len(EPOCH_PREFIX):]
            if tail.isdigit() and is_checkpoint(p):
                out[int(tail)] = p
        return out

    @property
    def actor_path(self) -> Path:
        return self.path / ACTOR_NAME

    @property
    def packaged(self) -> bool:
        """A run that ships with the package: read, never written."""
        return self.path.resolve() in {p.resolve() for p in PACKAGED.values()}

    def policy_checkpoint(self) -> Path:
        """The checkpoint that stands for the run's policy, by its method's rule (``spec.schedule.checkpoint``):
        ``best_robust`` (else ``final``, for a run that had no robustness check), or ``final``; a packaged run's
        exported actor."""
        if self.packaged:
            return self.actor_path
        rule = self.spec().schedule.checkpoint
        for name in (CHECKPOINT_PREFERENCE if rule == "best_robust" else (rule,)):
            if self.has_checkpoint(name):
                return self.checkpoint(name)
            if is_checkpoint(kept := aside(self.checkpoint(name))):  # a kill between two renames (not on Linux)
                print(f"note: {self.checkpoint(name)}: its replacement was interrupted; read from its previous copy "
                      f"{kept.name} (the run's next train or resume puts it back)", file=sys.stderr)
                return kept
        raise DragMeshError(f"{self.path}: no checkpoints/{rule} yet (its method reads its runs by their {rule} "
                            "checkpoint; name another: --checkpoint RUN/checkpoints/NAME)")

    def trained_epochs(self) -> int:
        """Epochs the run has finished (its log), 0 when it has no final checkpoint yet."""
        if not self.has_checkpoint("final"):
            return 0
        rows = self.log_rows()
        return int(rows[-1]["epoch"]) if rows else 0

    @staticmethod
    def of_checkpoint(path: str | Path) -> tuple[RunDir, Path]:
        """(the run, the checkpoint) of a checkpoint path, or of a run folder (its policy checkpoint)."""
        p = PACKAGED.get(str(path), Path(path))
        if str(path) in PACKAGED and not (p / ACTOR_NAME).is_file():
            raise DragMeshError(f"{p}: the packaged {path} is missing (reinstall dragmesh2-jax)")
        if (p / RECORD).is_file():
            run = RunDir(p)
            return run, run.policy_checkpoint()
        if is_checkpoint(p) and (p.parent.parent / RECORD).is_file():
            return RunDir(p.parent.parent), p
        if p.name == ACTOR_NAME and p.is_file() and (p.parent / RECORD).is_file():
            return RunDir(p.parent), p
        raise DragMeshError(f"{p}: no such checkpoint (a run folder, one of its checkpoints/*, or "
                            f"{' | '.join(PACKAGED)}: the packaged one)")

    # -------------------------------------------------------------------------------------- tables
    def log_rows(self, max_epoch: int | None = None) -> list[dict]:
        return self._rows("log", max_epoch)

    def robust_rows(self, max_epoch: int | None = None) -> list[dict]:
        return self._rows("robust", max_epoch)

    def write_log(self, rows: list[dict]) -> None:
        self._write_table("log", rows)

    def write_robust(self, rows: list[dict]) -> None:
        self._write_table("robust", rows)

    def _rows(self, stem: str, max_epoch: int | None) -> list[dict]:
        path = self.path / f"{stem}{ROWS}"
        if not path.is_file():
            return []
        try:
            rows = [json.loads(x) for x in path.read_text().splitlines() if x.strip()]
        except json.JSONDecodeError as e:
            raise DragMeshError(f"{path}: a row is not valid JSON ({e})") from None
        if not all(isinstance(r, dict) and isinstance(r.get("epoch"), int) for r in rows):
            raise DragMeshError(f"{path}: every row must be an object with an integer epoch")
        return [r for r in rows if max_epoch is None or r["epoch"] <= max_epoch]

    def _write_table(self, stem: str, rows: list[dict]) -> None:
        """``stem.jsonl`` and ``stem.csv`` (columns: every key, in the order first seen)."""
        atomic_write_text(self.path / f"{stem}{ROWS}", "".join(json.dumps(r) + "\n" for r in rows))
        keys = list(dict.fromkeys(k for r in rows for k in r))
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
        atomic_write_text(self.path / f"{stem}{CSV}", buf.getvalue())

    # -------------------------------------------------------------------------------- evaluations
    def evaluation_path(self, checkpoint: Path, protocol: EvalProtocol, suffix: str = ".json",
                        on: str | None = None) -> Path:
        """Where an evaluation goes: by checkpoint and protocol, and ``on`` another object than the run's own (a
        zero-shot evaluation, by the object's name: a folder given for it is named by its last part)."""
        where = f"__on-{Path(on).name}" if on else ""
        return self.path / EVALUATIONS / f"{checkpoint.name}__{protocol.name}{where}{suffix}"

    def write_evaluation(self, checkpoint: Path, protocol: EvalProtocol, result: dict, markdown: str,
                         on: str | None = None) -> Path:
        path = self.evaluation_path(checkpoint, protocol, on=on)
        with self.writing():
            atomic_write_json(path, result)
            atomic_write_text(self.evaluation_path(checkpoint, protocol, ".md", on), markdown + "\n")
        return path

    def evaluation(self, checkpoint: Path, protocol: EvalProtocol, on: str | None = None) -> dict | None:
        """The evaluation of ``checkpoint`` under ``protocol`` (``on`` another object) when one was written."""
        path = self.evaluation_path(checkpoint, protocol, on=on)
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError:
            return None  # damaged: evaluated again
