"""The notebooks run top to bottom on a tiny budget (``DRAGMESH2_NOTEBOOK_TINY=1``), as a user runs them, and show
what their text says they show: the object and its expert grasp as a picture, the expert drag opening the packaged
drawer, a run's record, its curves as a figure and its evaluation table, and brax's PPO training the task through
its Playground and brax envs, its reward as a figure."""

from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


def run_notebook(name: str, tmp_path) -> list[dict]:
    """Each code cell's outputs after running the notebook: {"text": what it printed or showed as text or
    markdown, "png": whether it showed a picture}."""
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    NotebookClient(nb, timeout=900, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    cells = []
    for c in (c for c in nb.cells if c.cell_type == "code"):
        outs = c.get("outputs", [])
        assert not [o for o in outs if o.output_type == "error"], c.source
        data = [o.get("data", {}) for o in outs]
        cells.append({"text": "".join([o.get("text", "") for o in outs] + [d.get(k, "") for d in data for k in (
            "text/plain", "text/markdown")]), "png": any("image/png" in d for d in data)})
    return cells


@pytest.fixture(autouse=True)
def tiny(monkeypatch):
    monkeypatch.setenv("DRAGMESH2_NOTEBOOK_TINY", "1")
    monkeypatch.delenv("DRAGMESH2_RUN", raising=False)


def test_the_quickstart_shows_the_object_its_expert_and_a_trained_policys_table(tmp_path):
    setup, summary, trajectory, grasp, track, train, table = run_notebook("quickstart.ipynb", tmp_path)
    assert "'type': 'prismatic'" in summary["text"] and "collision_pieces" in summary["text"]
    assert "'passed': True" in trajectory["text"] and "'drag'" in trajectory["text"]
    assert grasp["png"] and "renderer" in grasp["text"]
    assert track["text"].count("'success_rate': 1.0") >= 1  # the expert drag opens the drawer
    assert "| x1 | det |" in table["text"] and "| x4 | stoch |" in table["text"]
    assert "wrist load p95 [N]" in table["text"]


def test_a_trained_runs_record_curves_and_evaluation(tmp_path):
    _, record, curves, evaluation = run_notebook("trained_run.ipynb", tmp_path)
    assert "'method': 'pica'" in record["text"] and "'backend': 'mujoco'" in record["text"]
    assert curves["png"]
    assert "checkpoint `best_robust`, epoch" in evaluation["text"] and "| x2 | det |" in evaluation["text"]


def test_brax_ppo_trains_the_task_through_its_playground_and_brax_envs_and_plots_the_reward(tmp_path):
    _, playground, registered, train, train_playground, plot = run_notebook("brax_ppo.ipynb", tmp_path)
    assert "'history': (1632,)" in playground["text"] and "(tokens, token size): (16, 102)" in playground["text"]
    assert "action: 51" in playground["text"]
    assert "brax observation: 1752 = 120 + (16, 102)" in registered["text"]
    for env, text in (("brax env", train["text"]), ("Playground env", train_playground["text"])):
        assert text.count(f"{env}: ") == 3 and "success rate of the last evaluation" in text
    assert plot["png"]
