"""The expert's grasp chosen by what the evaluation measures: candidates replayed from clear starts, kept by the depth,
then the load held from every start, then the lighter pull (``task.choice``)."""

from dataclasses import replace

import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task import choice
from dragmesh2_jax.task.config import MAX_DEPTH, TaskConfig


def test_a_part_open_start_replays_the_drag_from_where_the_plan_reaches_the_part():
    targets = np.arange(10.0)[:, None] * np.ones((1, 3))
    schedule = np.array([0.0, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.5, 0.5, 0.5])
    np.testing.assert_array_equal(choice.from_part(targets, schedule, 0.0)[:, 0], np.arange(10.0))
    np.testing.assert_array_equal(choice.from_part(targets, schedule, 0.25)[:, 0], [4, 5, 6, 7, 8, 9, 9, 9, 9, 9])
    np.testing.assert_array_equal(choice.from_part(targets, schedule, 0.9)[:, 0], [9] * 10)  # past the plan: held


@pytest.fixture(scope="module")
def drawer_candidates():
    """The packaged drawer on the hand's contacts: its grasp seated there (on the bar's surface) and the grasp planned
    on MuJoCo's soft contacts (pressed into the bar, lighter where nothing resists)."""
    drawer, scene = str(packaged_object("drawer_cabinet_0000")), SceneConfig(object_contact="hand")
    seated = load_task(drawer, None, backend="mujoco", scene_config=scene, expert_grasp="seated")
    soft = load_task(drawer, None, backend="mujoco", scene_config=scene, expert_plan_contact="mujoco")
    return seated.scene, [("mujoco", soft.traj), ("hand", seated.traj)]


def test_the_choice_keeps_the_grasp_within_the_depth_over_one_listed_first_and_records_every_score(
        drawer_candidates, tmp_path, monkeypatch):
    monkeypatch.setenv("DRAGMESH2_CACHE", str(tmp_path))
    scene, candidates = drawer_candidates
    config = TaskConfig(backend="mujoco", expert_placement="starts")
    kept = choice.chosen(scene, candidates, config)
    scores = kept.header["generator"]["choice"]["scores"]
    assert kept.header["generator"]["choice"]["kept"] == 1 and kept.frames == candidates[1][1].frames
    assert [s["planned_in"] for s in scores] == ["mujoco", "hand"]
    assert not scores[0]["within_depth"] and scores[0]["deepest_m"] > MAX_DEPTH
    assert scores[1]["within_depth"] and scores[1]["held"] >= 8.0  # the drawer opens at x8 from every start
    assert kept.header["generator"]["choice"]["depth_bound_m"] == MAX_DEPTH
    assert choice.chosen(scene, candidates, config).header == kept.header  # the scores read back from the cache


def test_a_tighter_depth_bound_ranks_the_cached_scores_again_without_replaying_a_candidate(
        drawer_candidates, tmp_path, monkeypatch):
    monkeypatch.setenv("DRAGMESH2_CACHE", str(tmp_path))
    scene, candidates = drawer_candidates
    config = TaskConfig(backend="mujoco", expert_placement="starts")
    depths = [s["deepest_m"] for s in choice.chosen(scene, candidates, config).header["generator"]["choice"]["scores"]]

    def replayed(*_):
        raise AssertionError("a candidate replayed although its score is cached")
    monkeypatch.setattr(choice, "score", replayed)
    tight = replace(config, expert_depth=min(depths) / 2)  # no candidate within: held, then the pull, decide
    kept = choice.chosen(scene, candidates, tight).header["generator"]["choice"]
    assert kept["depth_bound_m"] == min(depths) / 2 and not any(s["within_depth"] for s in kept["scores"])
    assert [s["deepest_m"] for s in kept["scores"]] == depths
    held_first = choice.chosen(scene, candidates, replace(tight, expert_placement="starts_hold"))
    assert held_first.header["generator"]["choice"]["kept"] == 1  # the 2 mm still first, then the load held


def test_a_task_under_the_starts_choice_scores_each_placement_alone_and_keeps_one_within_the_depth():
    task = load_task(str(packaged_object("drawer_cabinet_0000")), None, backend="mujoco",
                     scene_config=SceneConfig(object_contact="hand"), expert_grasp="seated",
                     expert_placement="starts")
    g = task.traj.header["generator"]
    scores = g["choice"]["scores"]
    assert len(scores) >= 2 and {s["planned_in"] for s in scores} == {"hand"}  # the run's own contacts only
    assert len({repr(s["placement"]) for s in scores}) == len(scores)  # each placement generated alone
    best = scores[g["choice"]["kept"]]
    assert best["within_depth"] and best["held"] == max(s["held"] for s in scores if s["within_depth"])


def test_each_candidate_is_replayed_from_as_many_clear_starts_as_the_config_asks_and_scored_apart(
        drawer_candidates, tmp_path, monkeypatch):
    """``expert_choice_starts``: every damping replays each candidate from that many starts, and the scores of another
    count are cached apart (a wider choice never reads a narrower one's scores)."""
    monkeypatch.setenv("DRAGMESH2_CACHE", str(tmp_path))
    scene, candidates = drawer_candidates
    replays = []
    replay = choice.contacts.replay

    def counted(scene, start, *args):
        replays.append(start)
        return replay(scene, start, *args)
    monkeypatch.setattr(choice.contacts, "replay", counted)
    config = TaskConfig(backend="mujoco", expert_placement="starts", expert_choice_starts=2)
    score = choice.score(scene, candidates[1][1], config)
    tried = sum(d <= score["held"] for d in choice.CHOICE_DAMPINGS) + (score["held"] < choice.CHOICE_DAMPINGS[-1])
    assert len(replays) == 2 * tried  # the dampings held, and the first one not held
    replays.clear()
    choice.scores_of(scene, candidates[1:], config)
    narrow = len(replays)
    replays.clear()
    choice.scores_of(scene, candidates[1:], replace(config, expert_choice_starts=3))
    assert narrow > 0 and len(replays) > narrow  # not read from the 2-start scores' cache
