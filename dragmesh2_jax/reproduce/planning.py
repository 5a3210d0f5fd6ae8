"""The plan of a table: what to reproduce on (``ReproduceConfig``), its steps (training ``Run``s and ``Eval``uations, in
the order they run), and the plans recorded in a folder reproduced into."""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import MODES, PAPER, PAPER_DAMPINGS, EvalProtocol
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo.config import PAPER_EPOCHS
from dragmesh2_jax.render import VIDEO_EVERY
from dragmesh2_jax.reproduce.paper import (
    CHECKPOINTS,
    CONTINUED,
    DAMPING_RANGES,
    FINETUNE_EPOCHS,
    GENERALIST_FINETUNE_EPOCHS,
    GENERALIST_HOLDOUT,
    GENERALIST_OBJECTS,
    OOD_FINETUNES,
    PAPER_ROWS,
    PROJECT_EPISODES,
    PROJECT_TABLES,
    SCALING_OBJECTS,
    SCALING_POINTS,
    TABLES,
    TRAIN_LENGTHS,
)
from dragmesh2_jax.runs.commands import baseline_controllers
from dragmesh2_jax.runs.overrides import FIRM_GRIP
from dragmesh2_jax.runs.presets import METHODS, RECOMMENDED
from dragmesh2_jax.runs.rundir import RunDir, epoch_name
from dragmesh2_jax.runs.spec import method_defaults

#: The physics every row trains and is evaluated on (``reproduce --contacts``), as changes to the scene: MuJoCo's
#: default object contacts (the paper's tables as measured so far) or the hand's firm grip the recipe's levers hold
#: with (FIRM_GRIP: the fingers about 1 mm into a handle where the default lets them sink 4-9 mm).
CONTACTS = {"mujoco": {}, "hand": {k.removeprefix("scene."): v for k, v in FIRM_GRIP.items()}}


@dataclass(frozen=True)
class ReproduceConfig:
    """What to reproduce on: objects (the first is the diagnostic object of the appendix tables), seeds, the
    base budget (paper: 150 epochs; the appendix epochs scale with it), PPO batch, episodes per cell."""

    objects: tuple[str, ...]
    seeds: tuple[int, ...] = (0, 1, 2)
    epochs: int = PAPER_EPOCHS
    num_envs: int | None = None  # PPOConfig's (64)
    episodes: int | None = None  # per cell; None: the table's own (PAPER's 20, PROJECT_EPISODES for the project's)
    backend: str = "auto"
    eval_seed: int = 42
    methods: tuple[str, ...] | None = None  # the rows of the main and ablation tables; None: the paper's
    # the evaluation cells; None: the rows' methods' own (the recipe's x1-x16), else the paper's x1/x2/x4
    dampings: tuple[float, ...] | None = None
    video_every: int = VIDEO_EVERY  # a video per method and object (first seed), a frame every this many steps; 0: none
    train_objects: int = GENERALIST_OBJECTS  # generalist: procedural training objects (a dataset built in out)
    dataset: str | None = None  # generalist: a dataset folder (dataset build) to train on instead
    holdout: int = GENERALIST_HOLDOUT  # generalist: training objects held aside for best_robust
    scaling: tuple[int, ...] = SCALING_OBJECTS  # scaling: the training-set sizes
    modes: tuple[str, ...] = MODES  # the evaluation modes of trained runs (controllers are det only)
    # the checkpoint of each run a main or ablation cell evaluates: best_robust (selected during training by the
    # paper's robustness protocol), final (the run's last epoch), or None: each method's own rule
    checkpoint: str | None = None
    contacts: str = "mujoco"  # the physics of every row (CONTACTS)

    def __post_init__(self):
        if not self.objects:
            raise DragMeshError("reproduce needs at least one object")
        if self.methods is not None:  # "recommended" stands for the recipe (a row is labelled with its name)
            object.__setattr__(self, "methods", tuple(RECOMMENDED if m == "recommended" else m for m in self.methods))
        if self.dampings is None:
            own = sorted({d for m in self.methods or () if m in METHODS for d in method_defaults(m).schedule.dampings
                          or ()})
            object.__setattr__(self, "dampings", tuple(own) or PAPER_DAMPINGS)
        known = [*baseline_controllers(), *METHODS]
        unknown = [m for m in self.methods or () if m not in known]
        if self.methods is not None and (not self.methods or unknown):
            raise DragMeshError(f"unknown method(s) {', '.join(unknown) or '(none given)'} "
                                f"(choose from {', '.join(known)})")
        if not self.seeds or len(set(self.seeds)) < len(self.seeds):
            raise DragMeshError(f"reproduce needs distinct seeds, got {self.seeds}")
        if self.epochs < 1 or (self.episodes is not None and self.episodes < 1) or (
                self.num_envs is not None and self.num_envs < 1):
            raise DragMeshError("epochs, episodes and num_envs must be >= 1")
        if self.video_every < 0:
            raise DragMeshError(f"video_every must be >= 0 (0: no videos), got {self.video_every}")
        if self.dataset is None and not 0 <= self.holdout < self.train_objects:
            raise DragMeshError(f"the generalist needs --train-objects > --holdout >= 0, got {self.train_objects} "
                                f"and {self.holdout}")
        if not self.scaling or min(self.scaling) < 1 or len(set(self.scaling)) < len(self.scaling):
            raise DragMeshError(f"the scaling table needs distinct training-set sizes >= 1, got {self.scaling}")
        if self.checkpoint is not None and self.checkpoint not in CHECKPOINTS:
            raise DragMeshError(f"checkpoint must be one of {', '.join(CHECKPOINTS)}, got {self.checkpoint!r}")
        if self.contacts not in CONTACTS:
            raise DragMeshError(f"contacts must be one of {', '.join(CONTACTS)}, got {self.contacts!r}")
        if not self.modes or not set(self.modes) <= set(MODES):
            raise DragMeshError(f"evaluation modes must be some of {', '.join(MODES)}, got {self.modes}")

    def episodes_of(self, project: bool = False) -> int:
        """Episodes per cell: ``episodes``, else the paper's 20 for its tables and ``PROJECT_EPISODES`` for the
        project's own (``project``)."""
        return self.episodes or (PROJECT_EPISODES if project else PAPER.episodes)

    def protocol(self, project: bool = False) -> EvalProtocol:
        """How a trained run is evaluated (det and stoch) in a paper's table, or the project's (``project``)."""
        return EvalProtocol(dampings=self.dampings, modes=self.modes, episodes=self.episodes_of(project),
                            seed=self.eval_seed)

    @property
    def controller_protocol(self) -> EvalProtocol:
        """How a controller is evaluated (deterministic: det only, as the paper)."""
        return dataclasses.replace(self.protocol(), modes=("det",))

    @property
    def generalist_epochs(self) -> int:
        """The generalist's budget: as many env steps as the specialists of every object together."""
        return self.epochs * len(self.objects)

    @property
    def scaling_epochs(self) -> list[int]:
        """The epochs a scaling run is evaluated at: ``SCALING_POINTS`` checkpoints evenly along its budget."""
        every = max(1, self.generalist_epochs // SCALING_POINTS)
        return sorted({min(k * every, self.generalist_epochs) for k in range(1, SCALING_POINTS)}
                      | {self.generalist_epochs})

    def scaled(self, paper_epochs: int) -> int:
        """The paper's epoch count at this budget (``paper_epochs`` at 150 base epochs)."""
        return max(1, round(paper_epochs * self.epochs / PAPER_EPOCHS))


@dataclass(frozen=True)
class Run:
    """A training run folder: a base method, or a fine-tune ``recipe`` of ``parent`` (from its final
    checkpoint, which is at ``parent.epochs``). A run reaches ``epochs`` by resuming its folder, so one folder
    can be trained stage by stage. A ``generalist`` run trains over the dataset's objects (``object`` is then the
    dataset), a scaling run over the first ``train_objects`` of the scaling dataset in the Table 1 mix; a
    generalist's fine-tunes go onto their own ``object``."""

    object: str
    seed: int
    epochs: int
    method: str | None = None
    parent: Run | None = None
    recipe: str | None = None
    generalist: bool = False
    train_objects: int | None = None

    @property
    def name(self) -> str:
        if self.parent is not None:
            return f"{self.parent.name}+{self.recipe}"
        if self.train_objects:
            return f"generalist_{self.method}_n{self.train_objects}"
        return f"generalist_{self.method}" if self.generalist else self.method

    def folder(self, out: Path) -> RunDir:
        group = "scaling" if self.train_objects else "generalist" if self.generalist else Path(self.object).name
        return RunDir(out / "runs" / group / f"{self.name}_s{self.seed}")


@dataclass(frozen=True)
class Eval:
    """An evaluation: of a run's checkpoint (``best_robust``, or ``final``: the run's checkpoint at ``epoch``, by
    default ``run.epochs``), or of a controller ``controller`` on ``object``."""

    object: str
    run: Run | None = None
    checkpoint: str = "best_robust"
    controller: str | None = None
    seed: int = 0
    epoch: int | None = None
    project: bool = False  # a cell of the project's own tables (generalist, scaling): its protocol's episodes

    @property
    def at(self) -> int:
        """The epoch of a ``final`` checkpoint."""
        return self.epoch or self.run.epochs

    @property
    def zero_shot(self) -> bool:
        """An evaluation of a generalist on an object it did not train on."""
        return self.run is not None and self.run.generalist

    @property
    def on(self) -> str | None:
        """The object's name for a zero-shot evaluation (its file is keyed by it), else None."""
        return Path(self.object).name if self.zero_shot else None

    @property
    def label(self) -> str:
        """The row this evaluation fills: the controller or method, or ``run@epochs`` for a named epoch."""
        if self.run is None:
            return self.controller
        return self.run.name if self.checkpoint == "best_robust" else f"{self.run.name}@{self.at}"

    def checkpoint_path(self, out: Path) -> Path:
        run = self.run.folder(out)
        return run.checkpoint(self.checkpoint if self.checkpoint == "best_robust" else epoch_name(self.at))

    def path(self, out: Path, c: ReproduceConfig) -> Path:
        if self.run is None:
            name = f"{self.controller}__{c.controller_protocol.name}.json"
            return out / "controllers" / Path(self.object).name / name
        return self.run.folder(out).evaluation_path(self.checkpoint_path(out), c.protocol(self.project), on=self.on)


def generalist_methods(c: ReproduceConfig) -> tuple[str, ...]:
    """The generalist table's methods: ``methods``, else the project's recipe."""
    return c.methods or (RECOMMENDED,)


def plan(table: str, c: ReproduceConfig) -> list[Run | Eval]:
    """The steps of ``table`` in the order they run (a run before its evaluations and before its fine-tunes)."""
    if table not in TABLES:
        raise DragMeshError(f"unknown table {table!r} (choose from {', '.join(TABLES)}, all)")
    steps: list[Run | Eval] = []
    project = table in PROJECT_TABLES  # its cells take the project's protocol
    if table in ("main", "ablation"):
        known = baseline_controllers()
        rows = c.methods or PAPER_ROWS[table]
        controllers = [n for n in rows if n in known]
        methods = [n for n in rows if n not in controllers]
        for obj in c.objects:
            steps += [Eval(obj, controller=n) for n in controllers]
            for m in methods:
                for s in c.seeds:
                    r = Run(obj, s, c.epochs, method=m)
                    steps += [r, Eval(obj, r, c.checkpoint or method_defaults(m).schedule.checkpoint, seed=s)]
        return steps
    if table == "generalist":
        for m in generalist_methods(c):
            for s in c.seeds:
                general = Run(c.dataset or "dataset", s, c.generalist_epochs, method=m, generalist=True)
                steps += [general]
                for obj in c.objects:
                    special = Run(obj, s, c.epochs, method=m)
                    tuned = Run(obj, s, general.epochs + GENERALIST_FINETUNE_EPOCHS, parent=general,
                                recipe="continued")
                    cell = functools.partial(Eval, obj, seed=s, project=project)
                    steps += [cell(general), cell(general, "final"), special, cell(special), tuned,
                              cell(tuned, "final")]
        return steps
    if table == "scaling":
        for s in c.seeds:  # every size of a seed before the next seed: a partial table has every size
            for m in generalist_methods(c):
                for n in c.scaling:
                    run = Run("scaling_dataset", s, c.generalist_epochs, method=m, generalist=True, train_objects=n)
                    steps += [run, *(Eval(obj, run, "final", seed=s, epoch=e, project=project) for e in c.scaling_epochs
                                     for obj in c.objects)]
        return steps
    obj = c.objects[0]

    def staged(parent: Run, recipe: str, paper_stages: tuple[int, ...], paper_start: int, s: int) -> list:
        """One folder continuing ``parent`` with ``recipe``, evaluated at each stage (distinct epochs)."""
        ends = sorted({parent.epochs + c.scaled(e - paper_start) for e in paper_stages})
        return [x for e in ends for r in [Run(obj, s, e, parent=parent, recipe=recipe)]
                for x in (r, Eval(obj, r, "final", seed=s))]

    for s in c.seeds:
        base = Run(obj, s, c.epochs, method="pica")
        steps += [base, Eval(obj, base, "final", seed=s)]
        if table in ("train-length", "ood"):
            steps += staged(base, "continued", TRAIN_LENGTHS[1:], PAPER_EPOCHS, s)
        if table == "ood":
            for ft in OOD_FINETUNES:
                steps += staged(base, ft, (FINETUNE_EPOCHS,), 0, s)
        if table in ("continued", "damping-range"):
            both = Run(obj, s, c.epochs + c.scaled(FINETUNE_EPOCHS), parent=base, recipe="both")
            steps += [both, Eval(obj, both, "final", seed=s)]
            if table == "continued":
                steps += staged(both, "continued", CONTINUED, PAPER_EPOCHS + FINETUNE_EPOCHS, s)
            else:
                for recipe, k in DAMPING_RANGES:
                    steps += staged(both, recipe, (k,), 0, s)
    return steps


def stage_epochs(table: str, c: ReproduceConfig) -> dict[str, list[int]]:
    """The epochs each run of an appendix table is evaluated at, by run name (for the row labels)."""
    out: dict[str, list[int]] = {}
    for step in plan(table, c):
        if isinstance(step, Eval) and step.run is not None and step.seed == c.seeds[0]:
            out.setdefault(step.run.name, []).append(step.run.epochs)
    return out


PLAN_FILE = "reproduce_run.json"  # the plan of each table reproduced into a folder: its config, and the time taken


def read_plans(out: Path) -> dict[str, ReproduceConfig]:
    """The recorded plan of each table reproduced into ``out`` (none before the first run)."""
    path = out / PLAN_FILE
    if not path.is_file():
        return {}
    try:
        data = json.loads(path.read_text())
        # a folder reproduced before plans were kept per table: its one config for each of its tables
        plans = data["plans"] if "plans" in data else {t: data["config"] for t in data["tables"]}
        return {t: ReproduceConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.items()})
                for t, cfg in plans.items() if t in TABLES}
    except (json.JSONDecodeError, KeyError, TypeError, AttributeError) as e:
        raise DragMeshError(f"{path}: not a reproduction's plan ({e}); move it aside to start again") from None


def write_plans(out: Path, plans: dict[str, ReproduceConfig], seconds: float | None) -> None:
    atomic_write_json(out / PLAN_FILE, {"plans": {t: dataclasses.asdict(c) for t, c in plans.items()},
                                        "seconds": seconds})
