"""The rollout planner (evaluation/rollout.py): a learned actor's episode improved by playing out
its most likely other actions, without training on the scenario; never longer than the actor
alone, within its budget, and run by `evaluate --method rollout` as the planners' plans are."""
import dataclasses
import json

import pytest
import yaml

from marl_mrta.apps.evaluate import main as evaluate_main
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.reference import scheduling_instance
from marl_mrta.baselines.settings import RolloutBudget, load_baseline_settings
from marl_mrta.common.config import ConfigError
from marl_mrta.common.paths import default_config_path, package_root
from marl_mrta.env.settings import load_task_settings
from marl_mrta.evaluation.rollout import RolloutError, rollout_plan
from marl_mrta.mappo.policy import load_policy
from marl_mrta.model.scenario import load_scenario

JOIN = package_root() / "test" / "data" / "scenarios" / "join_2r4t.xml"
TURNED = package_root() / "test" / "data" / "scenarios" / "turned_3r5t.xml"


def as_it_is():
    """The configured budget on the floor as it is alone: what a test of the rollout's own search
    checks must not be found by another orientation instead."""
    return dataclasses.replace(load_baseline_settings().rollout, orientations=1)


def planned(path, budget, precedence_margin=0.0):
    scenario = load_scenario(path)
    task = load_task_settings()
    instance = scheduling_instance(scenario, task.min_step, task.goal_timeout, precedence_margin)
    return rollout_plan(load_policy("generalist"), scenario, instance, budget, "finished"), instance


def test_rollout_takes_the_optimum_the_actor_alone_misses():
    plan, instance = planned(JOIN, as_it_is())
    exact = solve_exact(instance)
    assert exact.proven_optimal
    assert plan.details["greedy_makespan"] > exact.makespan + 1e-6     # the actor alone misses it
    assert plan.complete and plan.logic_violations == 0
    assert plan.makespan == pytest.approx(exact.makespan, abs=1e-6)
    assert 1 < plan.details["play_outs"] < load_baseline_settings().rollout.max_rollouts


@pytest.mark.parametrize("name", ["lab_2r", "lab_4r"])   # lab_3r: below
def test_rollout_is_never_longer_than_the_actor_alone(name):
    plan, _ = planned(package_root() / "scenarios" / f"{name}.xml", RolloutBudget(alternatives=2, max_rollouts=60))
    assert plan.complete and plan.logic_violations == 0
    assert plan.makespan <= plan.details["greedy_makespan"] + 1e-9


def test_a_budget_of_one_play_out_is_the_actor_alone():
    """The orientations share the budget: the one play-out is the floor as it is."""
    plan, _ = planned(JOIN, RolloutBudget(alternatives=3, max_rollouts=1, orientations=8))
    assert plan.details["play_outs"] == 1 and plan.details["budget_reached"]
    assert len(plan.details["orientation_makespans"]) == 1 and plan.details["orientation"] == 0
    assert plan.makespan == pytest.approx(plan.details["greedy_makespan"], abs=1e-9)


@pytest.mark.slow
def test_the_turned_floor_finds_the_optimum_the_floor_as_it_is_misses():
    """The generalist reads the floor through offsets in the map's axes alone; on the floor turned
    by 180 degrees its rollout takes the optimum that its rollout on the floor as it is misses."""
    alone, instance = planned(TURNED, as_it_is())
    exact = solve_exact(instance)
    assert exact.proven_optimal
    assert alone.makespan > exact.makespan + 1e-6                       # the floor as it is misses it
    plan, _ = planned(TURNED, load_baseline_settings().rollout)
    assert plan.complete and plan.logic_violations == 0
    assert plan.makespan == pytest.approx(exact.makespan, abs=1e-6)
    tried = plan.details["orientation_makespans"]
    assert len(tried) == 8 and tried[0] == pytest.approx(alone.makespan, abs=1e-9)
    assert plan.details["orientation"] != 0 and tried[plan.details["orientation"]] == pytest.approx(plan.makespan)
    assert plan.details["greedy_makespan"] == alone.details["greedy_makespan"]   # the actor alone, as it is


def test_evaluate_runs_the_rollout_plan_beside_the_actor(tmp_path):
    out = tmp_path / "evaluate.json"
    code = evaluate_main(["--method", "policy,rollout", "--policy", "generalist", "--scenario", str(JOIN),
                          "--episodes", "1", "--quiet", "--out", str(out)])
    assert code == 0
    policy, rollout = json.loads(out.read_text())["results"]
    assert rollout["plan"]["method"] == "rollout"
    assert rollout["summary"]["ratio_to_exact"] == pytest.approx(1.0)
    assert policy["summary"]["makespan_mean"] > rollout["summary"]["makespan_mean"] + 1e-6   # the actor alone: longer
    assert rollout["summary"]["logic_consistent_pct"] == 100.0
    assert rollout["plan"]["details"]["play_outs"] > 1                 # the plan is the search's, not the actor's alone


def test_rollout_without_an_actor_is_one_line(tmp_path, capsys):
    code = evaluate_main(["--method", "rollout", "--scenario", str(JOIN), "--out", str(tmp_path / "e.json")])
    assert code == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "evaluate: --policy: the rollout method needs an actor file (--policy path/to/actor.pt)"]
    assert not (tmp_path / "e.json").exists()


@pytest.mark.parametrize("section, key, value", [
    ("rollout", "alternatives", 0), ("rollout", "max_rollouts", "many"), ("rollout", "orientations", 9),
    # the robots' own lookahead (evaluation/lookahead.py) searches a step the same way
    ("lookahead", "alternatives", -1), ("lookahead", "orientations", 9), ("lookahead", "max_play_outs", 0),
    ("lookahead", "max_play_outs", "many"), ("lookahead", "opening", "yes")])
def test_a_bad_search_budget_names_the_file_and_key(tmp_path, section, key, value):
    data = yaml.safe_load(default_config_path("task_baselines.yaml").read_text())
    data[section][key] = value
    path = tmp_path / "task_baselines.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as error:
        load_baseline_settings(path)
    assert str(path) in str(error.value) and f"{section}.{key}" in str(error.value)
    assert "\n" not in str(error.value)


def test_tasks_the_precedence_mask_holds_back_reach_lab_3r_optimum():
    """lab_3r's optimum sends a robot towards a successor whose predecessor a robot after it
    takes, which the actor's in-turn decision cannot choose (the actor alone misses it): the
    rollout tries such tasks too."""
    plan, instance = planned(package_root() / "scenarios" / "lab_3r.xml", as_it_is())
    exact = solve_exact(instance)
    assert exact.proven_optimal and plan.details["greedy_makespan"] > exact.makespan + 1e-6
    assert plan.makespan == pytest.approx(exact.makespan, abs=1e-6)


def test_the_rollout_keeps_a_precedence_margin_the_actor_alone_breaks():
    """On lab_4r the actor's own episode sends two robots to successors that they reach less than
    1 s after their predecessors' finish; with evaluate's --precedence-margin 1.0 (real.launch's
    precedence_margin:=1.0) that episode is no plan, and the rollout finds the margin's proven optimum."""
    lab_4r = package_root() / "scenarios" / "lab_4r.xml"
    plan, instance = planned(lab_4r, as_it_is(), precedence_margin=1.0)
    exact = solve_exact(instance)
    assert exact.proven_optimal
    assert plan.details["greedy_makespan"] is None       # the actor alone: 25.99 s, 0.23 s of margin
    assert plan.complete and plan.logic_violations == 0
    assert plan.instance.precedence_margin == 1.0
    assert plan.makespan == pytest.approx(exact.makespan, abs=1e-6)   # 31.03 s (the GA: 31.62 s)


def test_no_plan_within_the_margin_is_one_line():
    lab_4r = package_root() / "scenarios" / "lab_4r.xml"
    with pytest.raises(RolloutError) as error:
        planned(lab_4r, RolloutBudget(alternatives=3, max_rollouts=1), precedence_margin=1.0)
    assert "precedence margin of 1 s" in str(error.value) and "\n" not in str(error.value)
