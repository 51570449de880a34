"""The `evaluate` command: table, JSON and Gantt charts for plans, the random baseline and a
learned actor file, all scored through the environment; the reference's best makespan, lower
bound and gap; a 16-robot, 32-task scenario within a 4 GB address space; bad input is one line
and exit 2."""
import json
import math
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from marl_mrta.env.factory import make_env
from marl_mrta.apps.evaluate import main

ROOT = Path(__file__).resolve().parents[2]
LAB_2R = str(ROOT / "scenarios" / "lab_2r.xml")


def test_evaluate_writes_table_json_and_gantt(tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = main(["--method", "random,exact,auction", "--scenario", LAB_2R, "--episodes", "4", "--seed", "3",
                 "--out", str(out), "--quiet"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "ratio to exact" in printed and "exact allocation" in printed
    data = json.loads(out.read_text())
    exact = data["exact"]
    assert exact["proven_optimal"] and exact["logic_violations"] == 0
    by_method = {r["summary"]["method"]: r for r in data["results"]}
    assert set(by_method) == {"random", "exact", "auction"}
    exact_summary = by_method["exact"]["summary"]
    assert exact_summary["makespan_mean"] == pytest.approx(exact["makespan"])
    assert exact_summary["ratio_to_exact"] == pytest.approx(1.0)
    assert exact_summary["logic_consistent_pct"] == 100.0 and exact_summary["makespan_sd"] == 0.0
    assert by_method["random"]["summary"]["ratio_to_exact"] > 1.0
    assert len(by_method["random"]["episodes"]) == 4
    for result in data["results"]:
        png = Path(result["gantt"])
        assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        rep = result["representative_episode"]
        assert {"robot", "task", "start", "reach", "order", "logic_correct"} <= set(rep["entries"][0])


def test_policy_method_runs_a_saved_actor(tmp_path, capsys):
    torch = pytest.importorskip("torch")
    from marl_mrta.mappo.networks import Actor
    from marl_mrta.mappo.policy import save_actor
    env = make_env(LAB_2R)
    torch.manual_seed(0)
    actor_path = tmp_path / "actor.pt"
    save_actor(actor_path, Actor(env.obs_dim, env.n_actions, 16), obs_dim=env.obs_dim, n_agents=env.n_agents,
               append_agent_id=False, settings={}, scenario=LAB_2R, predecessors=env.scenario.predecessors)
    out = tmp_path / "policy.json"
    code = main(["--method", "policy", "--policy", str(actor_path), "--scenario", LAB_2R, "--episodes", "2",
                 "--no-exact", "--out", str(out), "--quiet"])
    assert code == 0
    summary = json.loads(out.read_text())["results"][0]["summary"]
    assert summary["method"] == "policy" and summary["episodes"] == 2 and summary["ratio_to_exact"] is None


@pytest.mark.parametrize("argv,message", [
    (["--method", "policy"], "evaluate: --policy: the policy method needs an actor file"),
    (["--method", "policy", "--policy", "/nonexistent/actor.pt"], "evaluate: /nonexistent/actor.pt: no such file"),
    (["--method", "greedy"], "evaluate: --method: greedy: choose from random, ga, exact, auction, policy"),
    (["--method", "random", "--episodes", "0"], "evaluate: --episodes: must be at least 1, got 0"),
    (["--method", "exact", "--time-limit", "0"], "evaluate: --time-limit: must be positive, got 0"),
    (["--method", "exact", "--workers", "0"], "evaluate: --workers: must be at least 1, got 0"),
    (["--method", "exact", "--precedence-margin", "-1"], "evaluate: --precedence-margin: must be a finite number"),
    (["--method", "exact", "--precedence-margin", "nan"], "evaluate: --precedence-margin: must be a finite number"),
    (["--method", "replan"], "evaluate: --method replan: the replanning allocator decides on events"),
    (["--method", "replan", "--executor", "ros"], "evaluate: --method replan: runs in process here"),
])
def test_bad_input_is_one_line_and_exit_2(argv, message, tmp_path, capsys):
    code = main(argv + ["--scenario", LAB_2R, "--out", str(tmp_path / "x.json"), "--quiet", "--no-exact"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [err[0]] and err[0].startswith(message)


def test_out_may_name_a_directory(tmp_path):
    code = main(["--method", "exact", "--scenario", LAB_2R, "--episodes", "1", "--out", str(tmp_path), "--quiet"])
    assert code == 0
    written = tmp_path / "evaluate_lab_2r_exact.json"
    assert json.loads(written.read_text())["results"][0]["summary"]["method"] == "exact"
    assert (tmp_path / "evaluate_lab_2r_exact_exact_gantt.png").exists()


def test_unwritable_out_is_one_line_before_any_episode(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("kept")
    code = main(["--method", "random", "--scenario", LAB_2R, "--episodes", "1", "--no-exact",
                 "--out", str(blocker / "x.json"), "--quiet"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [err[0]] and err[0].startswith(f"evaluate: --out {blocker / 'x.json'}: cannot make the directory")
    assert blocker.read_text() == "kept"


def test_evaluate_says_it_plans_the_reference_before_its_search(tmp_path, capsys):
    """The reference's search can take minutes before any robot moves: a line says so first."""
    assert main(["--method", "exact", "--scenario", LAB_2R, "--episodes", "1", "--out", str(tmp_path / "r.json"),
                 "--time-limit", "2", "--workers", "1"]) == 0
    err = capsys.readouterr().err
    planning = err.find("evaluate: planning the reference of lab_2r (2 robots, 8 tasks")
    assert 0 <= planning < err.find("reference: best"), err


def test_evaluate_reports_the_reference_with_its_bound_and_gap(tmp_path, capsys):
    out = tmp_path / "ref.json"
    assert main(["--method", "exact,auction", "--scenario", LAB_2R, "--episodes", "1", "--out", str(out), "--quiet",
                 "--time-limit", "2", "--workers", "1"]) == 0
    captured = capsys.readouterr()
    assert "reference: best" in captured.err and "proven optimal" in captured.err
    assert "ratios: makespan / the proven optimum" in captured.out
    data = json.loads(out.read_text())
    reference = data["reference"]
    assert reference["proven_optimal"] and reference["gap"] == 0.0 and reference["solver"] == "astar"
    assert reference["best_makespan"] == reference["lower_bound"] == data["exact"]["makespan"]
    summaries = {r["summary"]["method"]: r["summary"] for r in data["results"]}
    assert summaries["exact"]["ratio_basis"] == "exact" and summaries["exact"]["ratio_to_lower_bound"] == pytest.approx(1.0)


def _address_space_4_gb():
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


@pytest.mark.slow
def test_evaluate_finishes_16_robots_and_32_tasks_within_4_gb_of_address_space(tmp_path):
    """Every method's schedule and the reference's bound on site_16r, the process limited to a
    4 GB address space (a solver that outgrew its budget would be killed or fail to allocate)."""
    out = tmp_path / "site.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, str(ROOT / "scripts" / "evaluate"), "--method", "random,ga,auction,exact",
                             "--scenario", str(ROOT / "scenarios" / "site_16r.xml"), "--episodes", "1",
                             "--time-limit", "1", "--quiet", "--out", str(out)],
                            capture_output=True, text=True, env=env, timeout=600, preexec_fn=_address_space_4_gb)
    assert result.returncode == 0, result.stderr[-2000:]
    data = json.loads(out.read_text())
    reference = data["reference"]
    assert 0 < reference["lower_bound"] <= reference["best_makespan"] < math.inf
    assert reference["proven_optimal"] == (reference["gap"] == 0.0)
    for entry in data["results"]:
        summary = entry["summary"]
        assert summary["complete_pct"] == 100.0, summary["method"]
        if entry["plan"] is not None:
            assert sorted(t for tasks in entry["plan"]["robot_tasks"] for t in tasks) == sorted(
                t for tasks in data["exact"]["robot_tasks"] for t in tasks)
            assert summary["logic_consistent_pct"] == 100.0
    assert {e["summary"]["method"] for e in data["results"]} == {"random", "ga", "auction", "exact"}


@pytest.mark.slow
def test_a_precedence_margin_keeps_every_plan_in_order_by_that_much(tmp_path, capsys):
    """lab_4r's optimum leaves 0.67 s between B1's (B3's) finish and B2's (B4's) arrival; with a
    1 s margin every planner keeps at least 1 s there, at a longer makespan."""
    lab_4r = str(ROOT / "scenarios" / "lab_4r.xml")
    documents = {}
    for margin in ("0", "1"):
        out = tmp_path / f"margin_{margin}.json"
        assert main(["--method", "exact,ga,auction", "--scenario", lab_4r, "--episodes", "1", "--out", str(out),
                     "--quiet", "--precedence-margin", margin]) == 0
        documents[margin] = json.loads(out.read_text())
    assert documents["0"]["exact"]["thinnest_precedence_margin"] < 1.0
    assert documents["1"]["exact"]["makespan"] > documents["0"]["exact"]["makespan"]
    for result in documents["1"]["results"]:
        plan = result["plan"]
        assert plan["precedence_margin"] == 1.0 and plan["logic_violations"] == 0
        assert plan["thinnest_precedence_margin"] is None or plan["thinnest_precedence_margin"] > 1.0
        assert result["summary"]["complete_pct"] == 100.0 and result["summary"]["logic_consistent_pct"] == 100.0
    assert "with a precedence margin of 1 s" in capsys.readouterr().out


def test_the_replanning_allocator_finishes_a_live_fleet_that_a_fixed_plan_cannot(tmp_path):
    """live_lab_4r: tasks released late and tb3_1 lost at 8 s. The GA's plan, fixed at the start,
    leaves tb3_1's tasks undone; the replanning allocator finishes every task in order."""
    live = str(Path(__file__).resolve().parents[1] / "data" / "scenarios" / "live_lab_4r.xml")
    out = tmp_path / "live.json"
    assert main(["--scenario", live, "--method", "replan,ga", "--decision-mode", "event", "--episodes", "1",
                 "--out", str(out), "--quiet", "--no-exact"]) == 0
    summaries = {r["summary"]["method"]: r["summary"] for r in json.loads(out.read_text())["results"]}
    assert summaries["replan"]["complete_pct"] == 100.0 and summaries["replan"]["logic_consistent_pct"] == 100.0
    assert summaries["ga"]["complete_pct"] < 100.0


def test_a_live_scenario_in_synchronous_steps_is_one_line_and_exit_2(tmp_path, capsys):
    live = str(Path(__file__).resolve().parents[1] / "data" / "scenarios" / "live_lab_4r.xml")
    assert main(["--scenario", live, "--method", "ga", "--out", str(tmp_path / "x.json"), "--quiet", "--no-exact"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--decision-mode event" in err[0] and not (tmp_path / "x.json").exists()
