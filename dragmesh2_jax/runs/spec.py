"""What a run is, apart from how it is computed: :class:`RunSpec`, one tree of frozen configs: the method, the
object, every config it trains with (task, scene, PPO, network), its :class:`Schedule` (how long, from which seed,
how often it saves and checks, which checkpoint stands for it and where it is evaluated) and for a fine-tune its
recipe and the checkpoint it continues. A spec is made once from a method (:func:`method_spec`: the defaults, the
method's overrides, then the command's) or a fine-tune (:func:`finetune_spec`: the parent's spec with the recipe's
overrides), written into the run's record, and read back whole for resume, evaluation and fine-tunes. Methods and
fine-tunes are override sets, dotted paths into this tree (:func:`apply_overrides`).

The record (``run.json``, format 4): ``format``, ``method``, ``object``, ``objects``, ``holdout``, ``teachers`` (a
list, empty but for a distilled run; absent from older records), ``finetune``, ``parent``, ``backend`` (the engine it
trained on), ``buffers``, ``schedule``, ``ppo``, ``task``, ``scene``, ``network``, ``overrides`` (what the run
changes of its method's tree, by dotted path: for people; the reader rebuilds the run from the sections) and
``versions``. Formats 2 and 3 are read too: their ``ppo`` held the epochs and the seed (moved to the schedule); what
they did not record (the network's encoder and critic, the schedule's checkpoint rule and evaluation cells, and in
format 2 the network's sizes and the schedule's intervals) is the recorded method's.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, get_args

from dragmesh2_jax.assets.procedural import default_objects_dir
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import SELECTION
from dragmesh2_jax.io import object_hash
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PAPER_EPOCHS, PPOConfig
from dragmesh2_jax.runs.finetunes import get_finetune
from dragmesh2_jax.runs.presets import get_method, resolve
from dragmesh2_jax.runs.record import config_from_dict, config_to_dict, versions
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig, apply_overrides

SAVE_EVERY = 10  # epochs between a run's checkpoints
ROBUST_EVERY = 10  # epochs between the robustness checks that select best_robust (paper App. B.3)
#: Which checkpoint stands for a run: ``best_robust``, the paper's selection by robustness during training (App.
#: B.3-B.4; ``final`` where the run has none), or ``final``, its last epoch's.
CheckpointRule = Literal["best_robust", "final"]
CHECKPOINT_RULES = get_args(CheckpointRule)
#: 7: the perturbed starts kept clear around a seated grasp (before: around the grasp as written); 6: the perturbed
#: starts kept clear of the part (before: as drawn); 5: the object's contacts and the expert's grasp
#: (before: always MuJoCo's object contacts and the planned grasp);
#: 4: the schedule whole, the network's encoder and critic; 3: the network's sizes; 2: neither
RECORD_FORMAT = 7
READABLE_FORMATS = (2, 3, 4, 5, 6, 7)
RECORD_KEYS = ("method", "object", "ppo", "task")  # what every record must have


@dataclass(frozen=True)
class Schedule:
    """How a run is driven around its compiled epochs (no program reads it): its length, its seed, when it saves and
    checks, and how it is read afterwards."""

    epochs: int = PAPER_EPOCHS
    """training epochs (one rollout + update each); a resume to more extends the run"""
    seed: int = 42
    """the run's seed: its parameters, worlds and sampled actions"""
    save_every: int = SAVE_EVERY
    """epochs between checkpoints (and the last epoch)"""
    robust_every: int = ROBUST_EVERY
    """epochs between robustness checks selecting best_robust (and the last); 0: none"""
    robust_episodes: int = SELECTION.episodes
    """episodes per damping of a check (a mix: a held-aside object each)"""
    checkpoint: CheckpointRule = "best_robust"
    """the checkpoint that stands for the run: the best of its robustness checks, or its last epoch's"""
    dampings: tuple[float, ...] | None = None
    """the damping cells it is evaluated at by default; None: x1/x2/x4"""

    def __post_init__(self):
        if self.epochs < 1 or self.save_every < 1 or self.robust_every < 0 or self.robust_episodes < 1:
            raise DragMeshError(f"epochs, save_every and robust_episodes must be >= 1 and robust_every >= 0, got "
                                f"{self.epochs}, {self.save_every}, {self.robust_episodes} and {self.robust_every}")
        if self.checkpoint not in CHECKPOINT_RULES:
            raise DragMeshError(f"checkpoint must be one of {', '.join(CHECKPOINT_RULES)}, got {self.checkpoint!r}")
        if self.dampings is not None and not (self.dampings and all(0 < d < math.inf for d in self.dampings)):
            raise DragMeshError(f"dampings must be finite damping multipliers > 0, got {self.dampings}")


#: The record's config sections, each the class it is read into.
SECTIONS = {"schedule": Schedule, "ppo": PPOConfig, "task": TaskConfig, "scene": SceneConfig,
            "network": NetworkConfig}


@dataclass(frozen=True)
class RunSpec:
    method: str
    object: str
    """the object folder"""
    ppo: PPOConfig = PPOConfig()
    task: TaskConfig = TaskConfig()
    scene: SceneConfig = SceneConfig()
    network: NetworkConfig = NetworkConfig()
    schedule: Schedule = Schedule()
    finetune: str | None = None
    """a fine-tune's recipe"""
    parent: str | None = None
    """the checkpoint a fine-tune continues"""
    objects: tuple[str, ...] = ()
    """a run over several objects: all of them, ``object`` first (empty: one object)"""
    holdout: int = 0
    """the last ``holdout`` of ``objects`` are held aside: best_robust is chosen on them"""
    teachers: tuple[str, ...] = ()
    """a distilled run's teachers (``ppo.distill_coef``): checkpoints (a command's run folders pinned to theirs), each
    of a specialist on one of its training objects (``runs/teachers.py``)"""

    def __post_init__(self):
        if self.objects and self.objects[0] != self.object:
            raise DragMeshError("a run's objects list starts with its object")
        if not 0 <= self.holdout < max(len(self.objects), 1):
            raise DragMeshError(f"--holdout {self.holdout}: at least one of the {len(self.objects) or 1} object(s) "
                                "must be left to train on")

    @property
    def training_objects(self) -> tuple[str, ...]:
        every = self.objects or (self.object,)
        return every[:len(every) - self.holdout]

    @property
    def heldout_objects(self) -> tuple[str, ...]:
        return self.objects[len(self.objects) - self.holdout:] if self.holdout else ()

    def differences(self, method: str | None = None, object_dir: str | list[str] | None = None,
                    **changes: dict) -> list[str]:
        """What a command's flags would change in this recorded run, each as ``what given (recorded R)``: the
        method, the object(s) and any field given in ``changes`` (``ppo``, ``task``, ``scene``, ``network``,
        ``schedule``: field -> value; None values are flags not given). A resume continues a run exactly, so any of
        these is refused (but a longer schedule: ``runs/session.py``)."""
        out = []
        if method is not None and resolve(method) != self.method:
            out.append(f"method {resolve(method)} (recorded {self.method})")
        if object_dir:
            given = [str(Path(o).resolve()) for o in (object_dir if isinstance(object_dir, list) else [object_dir])]
            recorded = [str(Path(o).resolve()) for o in (self.objects or (self.object,))]
            if given != recorded:
                out.append(f"object {', '.join(given)} (recorded {', '.join(recorded)})")
        for group, fields in changes.items():
            config = getattr(self, group)
            for name, value in (fields or {}).items():
                if value is not None and value != getattr(config, name):
                    out.append(f"{group}.{name} {value} (recorded {getattr(config, name)})")
        return out

    def with_seed(self, seed: int) -> RunSpec:
        return dataclasses.replace(self, schedule=dataclasses.replace(self.schedule, seed=seed))

    def on(self, backend: str, impl: str = "auto") -> RunSpec:
        """The same run on another engine."""
        return dataclasses.replace(self, task=dataclasses.replace(self.task, backend=backend, impl=impl))

    def record(self, backend: str, buffers: dict | None = None) -> dict:
        """The record of this spec (``backend``: the engine it resolved to; ``buffers``: MJX's contact budget; a run
        over several objects names each with the content hash of its folder)."""
        objects = [{"folder": str(Path(o).resolve()), "hash": object_hash(o)} for o in self.objects]
        return {"format": RECORD_FORMAT, "method": self.method, "object": str(Path(self.object).resolve()),
                "objects": objects, "holdout": self.holdout,
                "teachers": [str(Path(t).resolve()) for t in self.teachers],
                "finetune": self.finetune, "parent": self.parent, "backend": backend, "buffers": buffers,
                **self.sections(), "overrides": self._overrides_json(), "versions": versions()}

    def _overrides_json(self) -> dict:
        """What the run changes of its method's tree (``overrides``), as JSON: read by people, not by the reader,
        which rebuilds the run from its sections."""
        return json.loads(json.dumps(self.overrides(method_defaults(self.method)), default=dataclasses.asdict))

    def overrides(self, base: RunSpec) -> dict[str, Any]:
        """What this spec's configs change of ``base``'s, by dotted path to the deepest field that differs (a nested
        config is compared field by field; an optional one set or unset is its whole value)."""
        def diff(a, b, path: str) -> dict[str, Any]:
            if a == b:
                return {}
            if dataclasses.is_dataclass(a) and type(a) is type(b):
                return {k: v for f in dataclasses.fields(a)
                        for k, v in diff(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}").items()}
            return {path: a}
        return {k: v for g in SECTIONS for k, v in diff(getattr(self, g), getattr(base, g), g).items()}

    def sections(self) -> dict:
        """The record's config sections (``SECTIONS``) as JSON."""
        return {k: config_to_dict(getattr(self, k)) for k in SECTIONS}

    @classmethod
    def from_record(cls, record: dict, where: str = "run record") -> RunSpec:
        """The spec a record holds, or one error line saying what is wrong with it."""
        if not isinstance(record, dict):
            raise DragMeshError(f"{where}: not a JSON object")
        fmt = record.get("format")
        if fmt not in READABLE_FORMATS:
            raise DragMeshError(f"{where}: record format {fmt!r} is not one this version reads "
                                f"({', '.join(map(str, READABLE_FORMATS))}); train the run again")
        missing = [k for k in RECORD_KEYS if k not in record]
        if missing:
            raise DragMeshError(f"{where}: the record has no {', '.join(missing)}")
        for k in ("method", "object"):
            if not isinstance(record[k], str):
                raise DragMeshError(f"{where}: {k} must be a string, got {record[k]!r}")
        for k in ("finetune", "parent"):
            if record.get(k) is not None and not isinstance(record[k], str):
                raise DragMeshError(f"{where}: {k} must be a string or null, got {record[k]!r}")
        get_method(record["method"])
        if record.get("finetune") is not None:
            get_finetune(record["finetune"])
        objects = record.get("objects") or []
        if not isinstance(objects, list) or not all(isinstance(o, dict) and isinstance(o.get("folder"), str)
                                                    for o in objects):
            raise DragMeshError(f"{where}: objects must be a list of {{folder, hash}}, got {objects!r}")
        teachers = record.get("teachers") or []
        if not isinstance(teachers, list) or not all(isinstance(t, str) for t in teachers):
            raise DragMeshError(f"{where}: teachers must be a list of checkpoints, got {teachers!r}")
        holdout = record.get("holdout", 0)
        if not isinstance(holdout, int):
            raise DragMeshError(f"{where}: holdout must be a whole number, got {holdout!r}")
        sections = {k: {} if record.get(k) is None else record[k] for k in SECTIONS}  # not recorded: the defaults
        for k, v in sections.items():
            if not isinstance(v, dict):
                raise DragMeshError(f"{where}: {SECTIONS[k].__name__} must be an object, got {type(v).__name__}")
        if fmt < 4:
            sections = _upgraded(record["method"], sections)
        if fmt < 5:  # made before the contacts and the grasp changed: read as made
            sections = {**sections, "scene": {"object_contact": "mujoco", **sections["scene"]},
                        "task": {"expert_grasp": "planned", **sections["task"]}}
        if fmt < 7 and isinstance(sections["task"].get("reset_noise"), dict):  # made before starts were seated
            made = {"clear": fmt >= 6, "seat": False}  # and before format 6, kept clear
            sections = {**sections, "task": {**sections["task"],
                                             "reset_noise": {**made, **sections["task"]["reset_noise"]}}}
        return cls(method=record["method"], object=installed(record["object"]),
                   objects=tuple(installed(o["folder"]) for o in objects),
                   holdout=holdout, teachers=tuple(teachers), finetune=record.get("finetune"),
                   parent=record.get("parent"),
                   **{k: config_from_dict(c, sections[k], where) for k, c in SECTIONS.items()})


def installed(folder: str) -> str:
    """A recorded object folder as this install has it: a packaged object recorded by another checkout or install of
    the package (``assets/procedural.default_objects_dir``, which a record names absolutely) is this one's; any
    other folder stands as recorded."""
    here, p = default_objects_dir(), Path(folder)
    if not p.is_dir() and p.parent.parts[-3:] == here.parts[-3:] and (here / p.name).is_dir():
        return str(here / p.name)
    return folder


def _upgraded(method: str, sections: dict) -> dict:
    """A format-2 or -3 record's sections as format 4 writes them: ``ppo``'s epochs and seed moved to the schedule,
    the method's network and schedule under what the record holds of them, and the method's own auxiliary weight:
    before format 4 the methods without the physical signals ignored the recorded one (now the weight decides)."""
    own = method_defaults(method)
    ppo = dict(sections["ppo"])
    moved = {k: ppo.pop(k) for k in ("epochs", "seed") if k in ppo}
    if "ppo.aux_weight" in get_method(method).overrides:
        ppo["aux_weight"] = own.ppo.aux_weight
    return {**sections, "ppo": ppo, "schedule": {**config_to_dict(own.schedule), **sections["schedule"], **moved},
            "network": {**config_to_dict(own.network), **sections["network"]}}


def method_defaults(method: str) -> RunSpec:
    """A method's tree on no object: the defaults with its overrides (what it trains with, for how long, how its
    runs are read)."""
    m = get_method(method)
    return apply_overrides(RunSpec(method=m.name, object=""), m.overrides)


def method_spec(method: str, object_dir: str | list[str], ppo: dict | None = None, task: dict | None = None,
                scene: dict | None = None, backend: str = "auto", impl: str = "auto",
                network: dict | None = None, holdout: int = 0, schedule: dict | None = None) -> RunSpec:
    """A new run of a method from Python: the method's tree (:func:`method_defaults`; ``recommended`` recorded as the
    recipe it stands for) with changes on top, each a group's fields: ``task``, ``scene``, ``network``, ``schedule``
    and ``ppo`` (its None values are not given: no PPO field takes None), on its objects (:func:`on_objects`). The
    command line passes its parsed tree whole instead."""
    given = {"task.backend": backend, "task.impl": impl,
             **{f"ppo.{k}": v for k, v in (ppo or {}).items() if v is not None}}
    for group, changes in (("task", task), ("scene", scene), ("network", network), ("schedule", schedule)):
        given |= {f"{group}.{k}": v for k, v in (changes or {}).items()}
    return on_objects(apply_overrides(method_defaults(method), given), object_dir, holdout)


def on_objects(tree: RunSpec, object_dir: str | list[str] | None, holdout: int = 0) -> RunSpec:
    """A run's tree on its object, or on several (a list: one policy over all of them, the last ``holdout`` held aside
    for checkpoint selection)."""
    objects = [str(o) for o in object_dir] if isinstance(object_dir, list | tuple) else []
    object_dir = objects[0] if objects else object_dir
    if not object_dir:
        raise DragMeshError("no object folder given (--object)")
    if len(objects) == 1:
        objects = []
    spec = apply_overrides(tree, {"object": str(object_dir), "objects": tuple(objects), "holdout": holdout})
    if spec.task.object_curriculum and len(spec.training_objects) < 2:
        raise DragMeshError("--task.object-curriculum draws among a run's training objects; this run trains on one")
    return spec


def finetune_spec(parent: RunSpec, recipe: str, checkpoint: str, epochs: int, schedule: dict | None = None
                  ) -> RunSpec:
    """A fine-tune of ``parent`` with ``recipe`` (its overrides on the parent's tree), from ``checkpoint``, to
    ``epochs`` (counted on from the checkpoint's epoch), ``schedule``'s other fields changed where given."""
    ft = get_finetune(recipe)
    untaught = {"teachers": (), "ppo.distill_coef": 0.0, "ppo.distill_epochs": 0}  # a fine-tune is PPO on its own
    return apply_overrides(parent, {**untaught, **ft.overrides,
                                    **{f"schedule.{k}": v for k, v in (schedule or {}).items()},
                                    "schedule.epochs": epochs, "finetune": recipe, "parent": str(checkpoint)})
