"""The report of a table: its markdown (the layout of each table described as data, ``LAYOUTS``), its JSON, and its
figures (Figure 2, the scaling figure, the training curves)."""

from __future__ import annotations

import dataclasses
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from matplotlib.figure import Figure

from dragmesh2_jax.evaluation.evaluate import PHYSICAL
from dragmesh2_jax.evaluation.protocol import MODES, PAPER_DAMPINGS
from dragmesh2_jax.io import atomic_write_figure, atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.reproduce.paper import (
    GENERALIST_FINETUNE_EPOCHS,
    GENERALIST_OBJECT_SEED,
    PAPER_CELLS,
    PROJECT_TABLES,
)
from dragmesh2_jax.reproduce.planning import Eval, ReproduceConfig, Run, generalist_methods, plan, stage_epochs

Column = tuple[str, float, str]  # an appendix table's column: mode, damping, metric


# ------------------------------------------------------------------------------------------ the tables
def _cell(results: list[dict], label: str, obj: str, damping: float, mode: str, key: str = "success_rate"):
    return [c[key] for r in results if r["label"] == label and r["object"] == obj for c in r["cells"]
            if c["damping"] == damping and c["mode"] == mode]


def _fmt(xs: list[float]) -> str:
    if not xs:
        return "-"
    if len(xs) == 1:
        return f"{xs[0]:.2f}"
    return f"{np.mean(xs):.2f}±{np.std(xs, ddof=1) / np.sqrt(len(xs)):.2f}"


def seeds_table(results: list[dict], labels: list[str], objects: list[str], seeds: tuple[int, ...],
                dampings: tuple[float, ...] = PAPER_DAMPINGS) -> str:
    """Every seed's success beside the means: method x damping x mode rows, one cell per object listing the values
    of ``seeds`` in that order, '-' for one not evaluated yet (a mean carried by one lucky seed shows here)."""
    names = [Path(o).name for o in objects]
    lines = ["| method | damp | mode | " + " | ".join(names) + " |", "|---|---|---|" + "---|" * len(names)]
    for label in labels:
        for d in dampings:
            for m in MODES:
                cells = []
                for o in names:
                    by_seed = {r["seed"]: c["success_rate"] for r in results if r["label"] == label
                               and r["object"] == o for c in r["cells"] if c["damping"] == d and c["mode"] == m}
                    cells.append(", ".join(f"{by_seed[x]:.2f}" if x in by_seed else "-" for x in seeds)
                                 if by_seed else "-")
                if any(x != "-" for x in cells):
                    lines.append(f"| {label} | x{d:g} | {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _paper(label: str, obj: str, damping: float) -> str:
    cell = PAPER_CELLS.get(label, {}).get(obj)
    if cell is None or damping not in PAPER_DAMPINGS:
        return ""
    det, stoch = cell[PAPER_DAMPINGS.index(damping)]
    return f" ({det:.2f}" + ("" if stoch is None else f"/{stoch:.2f}") + ")"


def comparison_table(results: list[dict], labels: list[str], objects: list[str],
                     dampings: tuple[float, ...] = PAPER_DAMPINGS) -> str:
    """Paper Table 2/3 layout: method x damping rows, det/stoch per object and the average over objects; the
    paper's det/stoch in parentheses for the objects it shares with ours."""
    names = [Path(o).name for o in objects]
    lines = ["| method | damp | " + " | ".join(names) + " | Avg |", "|---|---|" + "---|" * (len(names) + 1)]
    for label in labels:
        for d in dampings:
            row = []
            for o in names:
                det, stoch = _cell(results, label, o, d, "det"), _cell(results, label, o, d, "stoch")
                row.append(_fmt(det) + ("" if not stoch else " / " + _fmt(stoch)) + _paper(label, o, d))
            avg = [float(np.mean(_per_seed(results, label, names, d, m))) for m in MODES
                   if _per_seed(results, label, names, d, m)]
            row.append(" / ".join(_fmt(_per_seed(results, label, names, d, m)) for m in MODES
                                  if _per_seed(results, label, names, d, m)) + _paper(label, "Avg", d) if avg else "-")
            lines.append(f"| {label} | x{d:g} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def physical_table(results: list[dict], labels: list[str], objects: list[str],
                   dampings: tuple[float, ...] = PAPER_DAMPINGS) -> str:
    """How each row opened the parts: its det cells' saturation (the applied action's, and the policy's own: a
    residual's before it adds to the expert's) and physical figures (``evaluate.PHYSICAL``), the mean over objects and
    seeds (penetration: the deepest); '-' where no evaluation has them (an older one lacks the settled figures)."""
    names = [Path(o).name for o in objects]
    lines = ["| method | damp | clip099 active | policy's own | " + " | ".join(h for _, h, _ in PHYSICAL) + " |",
             "|---|---|---|---|" + "---|" * len(PHYSICAL)]
    for label in labels:
        for d in dampings:
            cs = [c for r in results if r["label"] == label and r["object"] in names for c in r["cells"]
                  if c["damping"] == d and c["mode"] == "det" and "wrist_load_peak_n" in c]
            if not cs:
                lines.append(f"| {label} | x{d:g} | " + " | ".join(["-"] * (len(PHYSICAL) + 2)) + " |")
                continue
            pick = {k: max if k == "penetration_max_mm" else np.mean for k, _, _ in PHYSICAL}
            own = [c["clip099_policy_active"] for c in cs if "clip099_policy_active" in c]  # not in older ones
            row = [f"{np.mean([c['clip099_active'] for c in cs]):.2f}", f"{np.mean(own):.2f}" if own else "-"] + [
                f.format(float(pick[k](v))) if (v := [c[k] for c in cs if k in c]) else "-" for k, _, f in PHYSICAL]
            lines.append(f"| {label} | x{d:g} | " + " | ".join(row) + " |")
    return "\n".join(lines)


def _per_seed(results: list[dict], label: str, names: list[str], damping: float, mode: str) -> list[float]:
    """Per seed, the success averaged over the objects (the Avg column's samples)."""
    seeds = sorted({r["seed"] for r in results if r["label"] == label})
    out = []
    for s in seeds:
        vals = [c["success_rate"] for r in results if r["label"] == label and r["seed"] == s and r["object"] in names
                for c in r["cells"] if c["damping"] == damping and c["mode"] == mode]
        if vals:
            out.append(float(np.mean(vals)))
    return out


def diagnostic_table(results: list[dict], rows: list[tuple[str, str]], columns: list[Column]) -> str:
    """Appendix layout: one row per (display name, run label), one column per (mode, damping, metric)."""
    head = " | ".join(f"{m} x{d:g} {'success' if k == 'success_rate' else k}" for m, d, k in columns)
    lines = [f"| variant | {head} |", "|---|" + "---|" * len(columns)]
    for name, label in rows:
        obj = next((r["object"] for r in results if r["label"] == label), None)
        cells = [_fmt(_cell(results, label, obj, d, m, k)) for m, d, k in columns] if obj else ["-"] * len(columns)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------- the figures
def figure2(results: list[dict], labels: list[str], objects: list[str], path: Path,
            dampings: tuple[float, ...] = PAPER_DAMPINGS) -> Path:
    """Success vs damping grouped by method (mean over objects, error bars: SE over seeds), det and stoch."""
    names = [Path(o).name for o in objects]
    fig = Figure(figsize=(11, 3.8))
    axes = fig.subplots(1, 2, sharey=True)
    width = 0.8 / max(len(labels), 1)
    for ax, mode in zip(axes, MODES, strict=True):
        for k, label in enumerate(labels):
            # a deterministic controller has no stochastic value: its det value stands in both panels (paper)
            m = mode if any(_per_seed(results, label, names, d, mode) for d in dampings) else "det"
            vals = [_per_seed(results, label, names, d, m) for d in dampings]
            mean = [np.mean(v) if v else np.nan for v in vals]
            se = [np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0 for v in vals]
            ax.bar(np.arange(len(dampings)) + (k - (len(labels) - 1) / 2) * width, mean, width, yerr=se,
                   label=label, capsize=2)
        ax.set_xticks(range(len(dampings)), [f"x{d:g}" for d in dampings])
        ax.set_title(f"{'(A) deterministic' if mode == 'det' else '(B) stochastic'}")
        ax.set_xlabel("damping multiplier")
        ax.set_ylim(0, 1.05)
    axes[0].set_ylabel(f"success (mean over {len(names)} objects)")
    if labels:  # beside the panels, where it hides no bar
        axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return atomic_write_figure(path, fig, dpi=110, bbox_inches="tight")


LINE_STYLES = ("-", "--", ":", "-.")  # one per damping in the scaling figure


def scaling_figure(results: list[dict], c: ReproduceConfig, path: Path) -> Path:
    """Zero-shot success (mean over the evaluated objects, error bars: SE over seeds) against the number of training
    objects at the full budget (a line per damping and mode), and against env steps (a line per size and damping,
    det)."""
    names = [Path(o).name for o in c.objects]
    steps_per_epoch = (c.num_envs or PPOConfig().num_envs) * PPOConfig().rollout_len
    fig = Figure(figsize=(11, 3.8))
    by_size, by_steps = fig.subplots(1, 2, sharey=True)

    def point(m: str, n: int, e: int, d: float, mode: str) -> tuple[float, float]:
        v = _per_seed(results, Eval(c.objects[0], Run("", 0, e, method=m, train_objects=n), "final").label, names,
                      d, mode)
        return (float(np.mean(v)) if v else np.nan), (np.std(v, ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0)

    sizes = sorted(c.scaling)
    for m in generalist_methods(c):
        for d in c.dampings:
            for mode in c.modes:
                mean, se = zip(*(point(m, n, c.generalist_epochs, d, mode) for n in sizes), strict=True)
                by_size.errorbar(sizes, mean, yerr=se, capsize=2, marker="o", ls="-" if mode == "det" else "--",
                                 label=f"{m} x{d:g} {mode}")
            for k, n in enumerate(sizes):
                mean, se = zip(*(point(m, n, e, d, "det") for e in c.scaling_epochs), strict=True)
                by_steps.errorbar([e * steps_per_epoch for e in c.scaling_epochs], mean, yerr=se, capsize=2,
                                  marker="o", color=f"C{k}", ls=LINE_STYLES[c.dampings.index(d) % len(LINE_STYLES)],
                                  label=f"{m} N={n} x{d:g}")
    by_size.set_xscale("log")
    by_size.minorticks_off()
    by_size.set_xticks(sizes, [str(n) for n in sizes])
    by_size.set_xlabel(f"training objects (each run {c.generalist_epochs * steps_per_epoch:,} env steps)")
    by_size.set_ylabel(f"zero-shot success (mean over {len(names)} objects)")
    by_steps.set_xlabel("env steps (det)")
    by_size.set_ylim(-0.02, 1.05)
    for ax in (by_size, by_steps):
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    return atomic_write_figure(path, fig, dpi=110, bbox_inches="tight")


def training_curves(table: str, c: ReproduceConfig, out: Path) -> Path | None:
    """Training success per epoch by method: the mean over the objects of each seed's curve, and over seeds with a
    band of one SE (the runs' logs as they are; a table's partial runs count as far as they went)."""
    curves: dict[str, dict[int, list[list[float]]]] = {}  # method -> seed -> one curve per object
    for run in (s for s in plan(table, c) if isinstance(s, Run)):
        rows = run.folder(out).log_rows() if run.folder(out).exists() else []
        if rows:
            curves.setdefault(run.name, {}).setdefault(run.seed, []).append([r["success"] for r in rows])
    if not curves:
        return None
    fig = Figure(figsize=(6.5, 3.8))
    ax = fig.subplots()
    for name, by_seed in curves.items():
        n = min(len(curve) for runs in by_seed.values() for curve in runs)
        y = np.asarray([np.mean([curve[:n] for curve in runs], axis=0) for runs in by_seed.values()])
        mean, se = y.mean(0), (y.std(0, ddof=1) / np.sqrt(len(y)) if len(y) > 1 else np.zeros(n))
        epochs = np.arange(1, n + 1)
        ax.plot(epochs, mean, label=name)
        ax.fill_between(epochs, mean - se, mean + se, alpha=0.25)
    ax.set_xlabel("epoch")
    ax.set_ylabel("training success (episodes ending in success)")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(f"{table}: mean over {len(c.objects)} object(s), band: SE over {len(c.seeds)} seed(s)")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return atomic_write_figure(out / f"curves_{table}.png", fig, dpi=110)


# ----------------------------------------------------------------------------------------- the layouts
@dataclass(frozen=True)
class Comparison:
    """A table of methods on every object (main, ablation; the project's generalist and scaling): the notes above
    its success tables (mean±SE, then every seed's), and what follows them."""

    #: "evaluated": a row per label in the order evaluated; "planned": the plan's, of the first seed and object
    rows: Literal["evaluated", "planned"]
    notes: Callable[[ReproduceConfig], list[str]]
    physical: bool = False  # the physical table of the det cells after the success tables
    #: a figure after the tables, drawn from (results, labels, config, path), its file name and its markdown text
    figure: Callable[[list[dict], list[str], ReproduceConfig, Path], Path] | None = None
    figure_name: str = ""  # {table} stands for the table's name
    figure_text: str = ""
    curves_and_videos: bool = False  # the training curves and the videos last

    def lines(self, table: str, c: ReproduceConfig, results: list[dict], out: Path) -> list[str]:
        if self.rows == "evaluated":
            labels = list(dict.fromkeys(r["label"] for r in results))
        else:
            labels = [s.label for s in plan(table, c) if isinstance(s, Eval) and s.seed == c.seeds[0]
                      and s.object == c.objects[0]]
        objects = list(c.objects)
        lines = [*self.notes(c), "", comparison_table(results, labels, objects, c.dampings), "",
                 f"Every seed's success (seeds {', '.join(map(str, c.seeds))}, in that order):", "",
                 seeds_table(results, labels, objects, c.seeds, c.dampings)]
        if self.physical:
            lines += ["", "How (det cells; mean over objects and seeds, penetration the deepest; the tracking row is "
                          "the expert's drag at its own pace):", "",
                      physical_table(results, labels, objects, c.dampings)]
        if self.figure is not None:
            fig = self.figure(results, labels, c, out / self.figure_name.format(table=table))
            lines += ["", f"![{self.figure_text}]({fig.name})"]
        if self.curves_and_videos:
            curves = training_curves(table, c, out)
            if curves is not None:
                lines += ["", f"![training curves]({curves.name})"]
            videos = sorted((out / "videos").glob("*")) if (out / "videos").is_dir() else []
            if videos:
                lines += ["", "Videos (first seed, deterministic, exact start, dampings side by side): " +
                          ", ".join(f"[{v.stem}](videos/{v.name})" for v in videos)]
        return lines


@dataclass(frozen=True)
class Diagnostic:
    """An appendix table on the diagnostic object: a row per run and epoch evaluated, the success at every mode and
    damping of the plan (where ``success``) and then ``columns``."""

    columns: tuple[Column, ...]
    success: bool = False

    def lines(self, table: str, c: ReproduceConfig, results: list[dict], out: Path) -> list[str]:
        rows = [(f"{name} ({e} ep)", f"{name}@{e}") for name, es in stage_epochs(table, c).items() for e in es]
        success = [(m, d, "success_rate") for m in MODES for d in c.dampings] if self.success else []
        return [f"Object {Path(c.objects[0]).name} (the paper's diagnostic object is 45936); mean±SE over seeds.", "",
                diagnostic_table(results, rows, [*success, *self.columns])]


def _paper_notes(c: ReproduceConfig) -> list[str]:
    return ["Cells: det / stoch success, mean±SE over seeds; (paper det/stoch) where the paper has the object."]


def _generalist_notes(c: ReproduceConfig) -> list[str]:
    return [f"Training objects: {_training_objects(c)}; the generalist trains {c.generalist_epochs} epochs (the "
            f"specialists' {c.epochs} x {len(c.objects)} objects), best_robust chosen on {c.holdout} held-aside "
            f"training objects; fine-tunes: {GENERALIST_FINETUNE_EPOCHS} epochs on the object from the "
            "generalist's final checkpoint.",
            "Rows: `M` the specialist (best_robust), `generalist_M` zero-shot (best_robust), "
            "`generalist_M@E` zero-shot (final), `generalist_M+continued@E` fine-tuned (final).",
            "Cells: det / stoch success, mean±SE over seeds."]


def _scaling_notes(c: ReproduceConfig) -> list[str]:
    return [f"Training objects: the first N of {max(c.scaling)} procedural objects in the paper's Table 1 mix "
            f"(seeds from {GENERALIST_OBJECT_SEED}; each size's objects hold the smaller sizes'), every size "
            f"trained for {c.generalist_epochs} epochs (the generalist's budget) without best_robust; every "
            "object evaluated zero-shot (never trained on).",
            "Rows: `generalist_M_nN@E`: method M over N training objects, its checkpoint at epoch E.",
            "Cells: det / stoch success, mean±SE over seeds."]


def _training_objects(c: ReproduceConfig) -> str:
    if c.dataset is not None:
        return f"the dataset {c.dataset}"
    return f"{c.train_objects} procedural objects in the paper's Table 1 mix (seeds from {GENERALIST_OBJECT_SEED})"


#: Paper Tables 2 and 3, with Figure 2.
PAPER_TABLE = Comparison("evaluated", _paper_notes, physical=True, curves_and_videos=True,
                         figure=lambda results, labels, c, path: figure2(results, labels, list(c.objects), path,
                                                                         c.dampings),
                         figure_name="figure2_{table}.png", figure_text="Figure 2")
#: Each table's layout, by name.
LAYOUTS: dict[str, Comparison | Diagnostic] = {
    "main": PAPER_TABLE,
    "ablation": PAPER_TABLE,
    "train-length": Diagnostic((("det", 1.0, "success_rate"), ("det", 4.0, "success_rate"), ("det", 4.0, "clip099"))),
    "ood": Diagnostic(tuple((m, 4.0, k) for m in MODES
                            for k in ("success_rate", "progress_mean", "return_mean", "clip099", "detach_rate"))),
    "continued": Diagnostic((("det", 4.0, "clip099"),), success=True),
    "damping-range": Diagnostic((), success=True),
    "generalist": Comparison("planned", _generalist_notes),
    "scaling": Comparison("planned", _scaling_notes, figure_name="scaling.png", figure_text="scaling",
                          figure=lambda results, labels, c, path: scaling_figure(results, c, path)),
}


def write_table(table: str, c: ReproduceConfig, results: list[dict], out: Path, keep_larger: bool = False) -> Path:
    """``<table>.md`` and ``<table>.json`` (and the table's figures) from the evaluations; with ``keep_larger`` (tables
    written without running) a table already there with more cells is kept (said on stderr), never replaced by a
    smaller one."""
    kept = _cells(out / f"{table}.json") if keep_larger else 0
    if kept > sum(len(r["cells"]) for r in results):
        print(f"note: {out / table}.md kept: it has {kept} cells, these evaluations "
              f"{sum(len(r['cells']) for r in results)}", file=sys.stderr)
        return out / f"{table}.md"
    budget = (f"{len(c.seeds)} seed(s) {', '.join(map(str, c.seeds))}; base {c.epochs} epochs; "
              f"{c.episodes_of(table in PROJECT_TABLES)} episodes per cell from distinct perturbed starts; backend "
              f"{c.backend}; {c.contacts}'s contacts")
    lines = [f"# reproduce {table}", "", budget, ""]
    missing = _missing(table, c, results)
    if missing:
        lines += [f"**Partial**: evaluations not done yet (their cells show fewer seeds or '-'): "
                  f"{'; '.join(missing)}.", ""]
    lines += LAYOUTS[table].lines(table, c, results, out)
    atomic_write_json(out / f"{table}.json", {"table": table, "config": dataclasses.asdict(c), "results": results})
    return atomic_write_text(out / f"{table}.md", "\n".join(lines) + "\n")


def _cells(path: Path) -> int:
    """The cells of a table's JSON written before (0: none, or unreadable, so replaced)."""
    try:
        return sum(len(r["cells"]) for r in json.loads(path.read_text())["results"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0


def _missing(table: str, c: ReproduceConfig, results: list[dict]) -> list[str]:
    """The plan's evaluations of ``table`` without a result, as ``object/label`` with the seeds they lack."""
    have = {(r["object"], r["label"], r["seed"]) for r in results}
    lacking: dict[str, list[str]] = {}
    for s in plan(table, c):
        if isinstance(s, Eval) and (Path(s.object).name, s.label, s.seed) not in have:
            lacking.setdefault(f"{Path(s.object).name}/{s.label}", []).append(str(s.seed))
    return [f"{k} (seed {','.join(v)})" for k, v in lacking.items()]
