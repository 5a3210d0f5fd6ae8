"""The README's command block runs as written, in order, as a new user would run it: from a folder with ``../shared``
beside it, each command's output feeding the next (``t.json``, ``objs``, ``runs/...``, ``curves.json``).

Only budgets are appended, where a command would take minutes or hours (``BUDGETS``; argparse keeps the last value
of a flag, so an appended flag replaces the written one). ``bench env`` is measured on the C engine here: its MJX
engines compile for minutes on a CPU and are measured by ``tests/test_bench.py`` and
``tests/physics/test_mjx_backend.py``. The ``reproduce`` plans (hours of training) run with their training and
evaluation steps replaced by stand-ins that leave what the real ones leave; ``tests/test_reproduce.py`` runs one
real table. ``view`` opens MuJoCo's viewer on a virtual screen, as its own process. ``train --generalist`` trains
over three procedural objects instead of its mix's fifty."""

import glob
import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.ppo.checkpoint import is_checkpoint
from dragmesh2_jax.ppo.config import PAPER_EPOCHS
from dragmesh2_jax.reproduce import executor
from tests.conftest import ROOT, SHARED, installed_command, require_shared
from tests.test_reproduce import FakeSteps

pytestmark = [pytest.mark.xdist_group(__name__), pytest.mark.long]

dragmesh2 = installed_command()
TRAIN = ["--epochs", "2", "--num-envs", "2", "--ppo.rollout-len", "8", "--robust-every", "0", "--network.state-sizes",
         "64,64", "--network.hist-dim", "32", "--network.heads", "2", "--network.critic-sizes", "64"]
#: Each command of the README's block by its start, in the README's order, with the flags appended for speed.
BUDGETS = [
    ("dragmesh2 inspect ", []),
    ("dragmesh2 objects list", []),
    ("dragmesh2 objects synth ", ["--category", "drawer_cabinet"]),
    ("dragmesh2 objects twin ", []),
    ("dragmesh2 trajectory ", []),
    ("dragmesh2 dataset build --objects ", []),
    ("dragmesh2 dataset build --procedural ", ["--procedural", "1"]),
    ("dragmesh2 evaluate --method tracking ", ["--episodes", "1"]),
    ("dragmesh2 evaluate --method parallel_jaw ", ["--episodes", "1"]),
    ("dragmesh2 envelope ", ["--paces", "1", "--damping", "1"]),
    ("dragmesh2 bench env ", ["--backend", "mujoco", "--num-envs", "1", "--steps", "2"]),
    ("dragmesh2 train --method pica --object ../shared/gapartnet/45261 --out runs/pica_45261", TRAIN),
    ("dragmesh2 train --out runs/pica_45261 --resume", ["--epochs", "3"]),
    ("dragmesh2 train --method recommended ", TRAIN),
    ("dragmesh2 train --method pica --object ../shared/gapartnet/45261 --out runs/pica3 ", TRAIN),
    ("dragmesh2 train --method pica --objects ", TRAIN),
    ("dragmesh2 train --method pica --dataset ", TRAIN),
    ("dragmesh2 train --generalist ", TRAIN),
    ("dragmesh2 evaluate --checkpoint generalist ", ["--episodes", "1", "--mode", "det", "--damping", "1"]),
    ("dragmesh2 open ", ["--episodes", "1", "--video-every", "100"]),
    ("dragmesh2 evaluate --checkpoint runs/pica_45261 ", ["--episodes", "1"]),
    ("dragmesh2 evaluate --checkpoint runs/hold", ["--episodes", "1", "--mode", "det"]),
    ("dragmesh2 evaluate --checkpoint runs/mix ", ["--episodes", "1", "--mode", "det"]),
    ("dragmesh2 finetune --checkpoint runs/mix ", ["--epochs", "1"]),
    ("dragmesh2 finetune --checkpoint runs/pica_45261 ", ["--epochs", "1"]),
    ("dragmesh2 bench train ", ["--num-envs", "2", "--runs", "1,2", "--epochs", "1"]),
    ("dragmesh2 bench learning --record ", ["--epochs", "1", "--seeds", "0"]),
    ("dragmesh2 bench learning --against ", []),
    ("dragmesh2 video ", ["--damping", "1,2", "--video-every", "100"]),
    ("dragmesh2 view --checkpoint ", ["--steps", "3"]),
    ("dragmesh2 view --object ", ["--steps", "3"]),
    ("dragmesh2 reproduce main ablation --objects ", []),
    ("dragmesh2 reproduce main ablation --out rep --tables-only", []),
    ("dragmesh2 reproduce main --methods state_only,pica,pica_load ", []),
    ("dragmesh2 reproduce main --methods recommended ", []),
    ("dragmesh2 reproduce generalist ", ["--train-objects", "2", "--holdout", "1"]),
    ("dragmesh2 reproduce scaling ", ["--scaling", "1,2"]),
    ("dragmesh2 reproduce all ", ["--train-objects", "2", "--holdout", "1"]),
]


def readme_commands() -> list[str]:
    """The commands of the README's command block (after ``## Command line``), comments cut."""
    text = (ROOT / "README.md").read_text()
    block = text.split("## Command line", 1)[1].split("```bash\n", 1)[1].split("```", 1)[0]
    return [re.split(r"\s+#", line, maxsplit=1)[0].strip() for line in block.splitlines()
            if line.startswith("dragmesh2 ")]


def argv_of(command: str) -> list[str]:
    """The arguments a shell would pass: words split, globs expanded (sorted, as bash does)."""
    out = []
    for word in shlex.split(command)[1:]:
        out += sorted(glob.glob(word)) or [word] if "*" in word else [word]
    return out


def test_every_command_of_the_block_has_its_budget_in_order():
    commands = readme_commands()
    assert len(commands) == len(BUDGETS), [c for c in commands if not any(c.startswith(p) for p, _ in BUDGETS)]
    for command, (start, _) in zip(commands, BUDGETS, strict=True):
        assert command.startswith(start), (command, start)


def test_the_readme_commands_run_as_written(tmp_path, monkeypatch, capsys, display):
    require_shared(SHARED / "gapartnet")
    work = tmp_path / "repo"
    work.mkdir()
    (tmp_path / "shared").symlink_to(SHARED.resolve())  # ../shared beside the folder the commands run in
    monkeypatch.chdir(work)
    fake = FakeSteps()
    monkeypatch.setattr(executor, "_train", fake.train)
    monkeypatch.setattr(executor, "_evaluate", fake.evaluate)
    monkeypatch.setattr(procedural, "GENERALIST_MIX", {"drawer_cabinet": 2, "door_cabinet": 1})  # 3, not 50
    env = {**{k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}, "DISPLAY": display}
    printed = {}  # each command's (stdout, stderr), by its start in BUDGETS
    for command, (start, budget) in zip(readme_commands(), BUDGETS, strict=True):
        argv = argv_of(command) + budget
        if argv[0] == "view":  # MuJoCo's viewer in its own process, on the virtual screen
            done = subprocess.run([str(Path(sys.executable).parent / "dragmesh2"), *argv], capture_output=True,
                                  text=True, env=env, timeout=600)
            assert done.returncode == 0, (command, done.stderr[-2000:])
            assert "view: 3 control steps shown" in done.stderr
            continue
        assert dragmesh2(argv) == 0, command
        printed[start] = capsys.readouterr()
    # what the commands print and leave is what the README says they do
    inspect = printed["dragmesh2 inspect "].out
    assert "StorageFurniture" in inspect and "prismatic" in inspect and "picture       grasp.png" in inspect
    assert Path("grasp.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and Path("envelope.png").is_file()
    assert Path("t.json").is_file() and Path("dataset/manifest.csv").is_file() and Path("curves.json").is_file()
    assert json.loads(Path("mw_twin/meta.json").read_text())["generator"]["twin"]["handle_length"] > 0
    for run in ("pica_45261", "hold", "pica3/seed_2", "mix", "ds", "mix_45780", "pica_45261_aram"):
        assert is_checkpoint(Path("runs", run, "checkpoints", "final")), run
    # a log gets one plain progress line per epoch, with the time taken and left
    pica = "dragmesh2 train --method pica --object ../shared/gapartnet/45261 --out runs/pica_45261"
    lines = [ln for ln in printed[pica].err.splitlines() if ln.startswith("train pica: epoch")]
    assert [ln.split()[3] for ln in lines] == ["1/2", "2/2"]
    assert all(re.search(r"elapsed \d+ s  left ~\d+ s$", ln) for ln in lines)
    assert '"epochs": 3' in Path("runs/pica_45261/run.json").read_text()  # the resume extended the record
    record = json.loads(Path("runs/pica3/seed_1/run.json").read_text())  # every flag reaches the record
    assert record["task"]["alpha"] == 0.03 and record["scene"]["damping"] == 25.0 and record["schedule"]["seed"] == 1
    assert record["network"]["state_sizes"] == [64, 64] and record["ppo"]["num_envs"] == 2
    generalist = json.loads(Path("runs/gen/run.json").read_text())  # its method over its mix, held aside by category
    assert generalist["method"] == "generalist" and generalist["holdout"] == 2 and len(generalist["objects"]) == 3
    opened = json.loads(Path("open_45780/report.json").read_text())  # the packaged generalist on a shared door
    assert opened["method"] == "generalist" and Path("open_45780/still.png").is_file()
    # zero-shot on an unseen folder: its own evaluation file; the fine-tune onto it is a run of that object alone
    (zero_shot,) = Path("runs/mix/evaluations").glob("*__on-45780.json")
    assert json.loads(zero_shot.read_text())["zero_shot"]
    tuned = json.loads(Path("runs/mix_45780/run.json").read_text())
    assert tuned["object"].endswith("45780") and tuned["objects"] == [] and tuned["finetune"] == "continued"
    assert list(Path("runs/pica_45261/evaluations").glob("*.json")) and list(Path(".").glob("pica.*"))
    # the recipe, trained and evaluated with no checkpoint or damping flag: its final checkpoint at x1-x8 and x16
    (recipe,) = Path("runs/hold/evaluations").glob("*.json")
    cells = json.loads(recipe.read_text())["cells"]
    assert recipe.name.startswith("final__") and [c["damping"] for c in cells] == [1.0, 2.0, 4.0, 8.0, 16.0]
    # bench train: s/epoch and env steps/s of each column of seeds, and the paper's budget from them
    one, column = json.loads(printed["dragmesh2 bench train "].out)
    assert (one["runs"], column["runs"]) == (1, 2)
    for r in (one, column):
        assert r["env_steps_per_s"] == pytest.approx(r["runs"] * 2 * 32 / r["s_per_epoch"], rel=1e-2)
        assert r["budget_s"] == pytest.approx(r["first_epoch_s"] + (PAPER_EPOCHS - 1) * r["s_per_epoch"], abs=0.2)
    for table in ("rep/main.md", "rep/ablation.md", "rep2/main.md", "rep4/main.md", "gen/generalist.md",
                  "scal/scaling.md", "tiny/damping-range.md"):
        assert Path(table).is_file(), table
    assert "| state_only | x8 |" in Path("rep2/main.md").read_text()
