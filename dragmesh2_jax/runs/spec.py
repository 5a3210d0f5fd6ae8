"""What a run is, apart from how it is computed: :class:`RunSpec`, the method, the object, every config it trains
with (task, scene, PPO, network), and for a fine-tune its recipe and the checkpoint it continues. A spec is made
once from a method preset (:func:`method_spec`) or a fine-tune (:func:`finetune_spec`), written into the run's
record, and read back whole for resume, evaluation and fine-tunes.

The record (``run.json``, format 3): ``format``, ``method``, ``object``, ``finetune``, ``parent``, ``backend``
(the engine it trained on), ``ppo``, ``task``, ``scene``, ``network`` and ``versions``. Format 2 (no ``network``:
the default sizes) is read too.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import hash_files
from dragmesh2_jax.policies.methods import CHECKPOINT_RULES, Method, get_method, resolve, task_overrides
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.finetune import get_finetune
from dragmesh2_jax.runs.record import config_from_dict, config_to_dict, versions
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig

SAVE_EVERY = 10  # epochs between a run's checkpoints
ROBUST_EVERY = 10  # epochs between the robustness checks that select best_robust (paper App. B.3)
RECORD_FORMAT = 3  # 3: the network config; 2: without it (the default sizes)
READABLE_FORMATS = (2, 3)
RECORD_KEYS = ("method", "object", "ppo", "task")  # what every record must have


@dataclass(frozen=True)
class RunSpec:
    method: str
    object: str  # the object folder
    ppo: PPOConfig = PPOConfig()
    task: TaskConfig = TaskConfig()
    scene: SceneConfig = SceneConfig()
    network: NetworkConfig = NetworkConfig()
    finetune: str | None = None  # a fine-tune's recipe
    parent: str | None = None  # the checkpoint a fine-tune continues
    objects: tuple[str, ...] = ()  # a run over several objects: all of them, ``object`` first (empty: one object)
    holdout: int = 0  # the last ``holdout`` of ``objects`` are held aside: best_robust is chosen on them
    save_every: int = SAVE_EVERY  # epochs between checkpoints (and the last epoch)
    robust_every: int = ROBUST_EVERY  # epochs between robustness checks (and the last epoch); 0: none
    checkpoint: str = "best_robust"  # the checkpoint that stands for the run (its method's rule, CHECKPOINT_RULES)

    def __post_init__(self):
        if self.checkpoint not in CHECKPOINT_RULES:
            raise DragMeshError(f"checkpoint must be one of {', '.join(CHECKPOINT_RULES)}, got {self.checkpoint!r}")
        if self.save_every < 1 or self.robust_every < 0:
            raise DragMeshError(f"save_every must be >= 1 and robust_every >= 0, got {self.save_every} and "
                                f"{self.robust_every}")
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

    @property
    def schedule(self) -> tuple[int, int, int]:
        """(epochs, save_every, robust_every): what a resume may change."""
        return self.ppo.epochs, self.save_every, self.robust_every

    @property
    def preset(self) -> Method:
        """The method preset with this run's network."""
        return dataclasses.replace(get_method(self.method), network=self.network)

    def differences(self, method: str | None = None, object_dir: str | list[str] | None = None,
                    **changes: dict) -> list[str]:
        """What a command's flags would change in this recorded run, each as ``what given (recorded R)``: the
        method, the object(s) and any field given in ``changes`` (``ppo``, ``task``, ``scene``, ``network``: field ->
        value; None values are flags not given). A resume continues a run exactly, so any of these is refused."""
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
        return dataclasses.replace(self, ppo=dataclasses.replace(self.ppo, seed=seed))

    def on(self, backend: str, impl: str = "jax") -> RunSpec:
        """The same run on another engine."""
        return dataclasses.replace(self, task=dataclasses.replace(self.task, backend=backend, impl=impl))

    def record(self, backend: str, buffers: dict | None = None) -> dict:
        """The record of this spec (``backend``: the engine it resolved to; ``buffers``: MJX's contact budget; a run
        over several objects names each with the content hash of its folder)."""
        objects = [{"folder": str(Path(o).resolve()), "hash": object_hash(o)} for o in self.objects]
        return {"format": RECORD_FORMAT, "method": self.method, "object": str(Path(self.object).resolve()),
                "objects": objects, "holdout": self.holdout,
                "finetune": self.finetune, "parent": self.parent, "backend": backend, "buffers": buffers,
                "schedule": {"save_every": self.save_every, "robust_every": self.robust_every,
                             "checkpoint": self.checkpoint},
                "ppo": config_to_dict(self.ppo), "task": config_to_dict(self.task),
                "scene": config_to_dict(self.scene), "network": config_to_dict(self.network), "versions": versions()}

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
        holdout = record.get("holdout", 0)
        if not isinstance(holdout, int):
            raise DragMeshError(f"{where}: holdout must be a whole number, got {holdout!r}")
        schedule = record.get("schedule") or {}  # runs recorded before it kept the defaults
        if not isinstance(schedule, dict) or not all(isinstance(schedule.get(k, 0), int) and not isinstance(
                schedule.get(k, 0), bool) for k in ("save_every", "robust_every")):
            raise DragMeshError(f"{where}: schedule must hold whole numbers save_every and robust_every, got "
                                f"{schedule!r}")
        if schedule.get("checkpoint", "best_robust") not in CHECKPOINT_RULES:
            raise DragMeshError(f"{where}: schedule.checkpoint must be one of {', '.join(CHECKPOINT_RULES)}")
        return cls(method=record["method"], object=record["object"], objects=tuple(o["folder"] for o in objects),
                   holdout=holdout, ppo=config_from_dict(PPOConfig, record["ppo"], where),
                   task=config_from_dict(TaskConfig, record["task"], where),
                   scene=config_from_dict(SceneConfig, record.get("scene", {}), where),
                   network=config_from_dict(NetworkConfig, record.get("network", {}), where),
                   finetune=record.get("finetune"), parent=record.get("parent"),
                   save_every=schedule.get("save_every", SAVE_EVERY),
                   robust_every=schedule.get("robust_every", ROBUST_EVERY),
                   checkpoint=schedule.get("checkpoint", "best_robust"))


def method_spec(method: str, object_dir: str | list[str], ppo: dict | None = None, task: dict | None = None,
                scene: dict | None = None, backend: str = "auto", impl: str = "jax",
                network: dict | None = None, holdout: int = 0) -> RunSpec:
    """A new run of a method preset: the preset's task (its overrides of the paper's) with ``task`` (TaskConfig
    fields) on top, the default scene with ``scene`` on top, the PPO defaults with ``ppo`` on top (None values
    keep the default), the preset's network with ``network`` (NetworkConfig fields) on top. ``object_dir`` may be
    a list of object folders: one policy over all of them, the last ``holdout`` held aside for checkpoint
    selection."""
    objects = [str(o) for o in object_dir] if isinstance(object_dir, list | tuple) else []
    object_dir = objects[0] if objects else object_dir
    if not object_dir:
        raise DragMeshError("no object folder given (--object)")
    if len(objects) == 1:
        objects = []
    m = get_method(method)
    method = m.name  # "recommended" recorded as the recipe it stands for
    task_config = TaskConfig(backend=backend, impl=impl, **{**task_overrides(m), **(task or {})})
    budget = {} if m.epochs is None else {"epochs": m.epochs}  # the method's own budget unless one is given
    return RunSpec(method=method, object=str(object_dir), objects=tuple(objects), holdout=holdout,
                   checkpoint=m.checkpoint,
                   ppo=PPOConfig(**{**budget, **{k: v for k, v in (ppo or {}).items() if v is not None}}),
                   task=task_config, scene=dataclasses.replace(SceneConfig(), **(scene or {})),
                   network=dataclasses.replace(m.network, **(network or {})))


def finetune_spec(parent: RunSpec, recipe: str, checkpoint: str, epochs: int) -> RunSpec:
    """A fine-tune of ``parent`` with ``recipe`` (its task overrides on the parent's task), from ``checkpoint``,
    to ``epochs`` (counted on from the checkpoint's epoch)."""
    ft = get_finetune(recipe)
    task = dataclasses.replace(parent.task, **ft.task_overrides(parent.task.reward))
    return dataclasses.replace(parent, task=task, ppo=dataclasses.replace(parent.ppo, epochs=epochs),
                               finetune=recipe, parent=str(checkpoint))


def object_hash(folder: str | Path) -> str:
    """The content hash of an object folder: every file under it, in path order."""
    root = Path(folder)
    files = sorted(p for p in root.rglob("*") if p.is_file())
    if not files:
        raise DragMeshError(f"{root}: no object files to hash")
    return hash_files(files, extra="\n".join(str(p.relative_to(root)) for p in files))
