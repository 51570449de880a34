"""bench_scale's parts: a run of some parts on some sizes keeps every other figure of the file
already there (and the settings its kept MAPPO figures were run with), fills the MAPPO figures
from a real fine-tuning run, and refuses a bad option with one line."""
import json

import pytest

from marl_mrta.apps.bench_scale import main as bench_scale_main
from marl_mrta.baselines.exact import solve_exact
from marl_mrta.baselines.reference import scheduling_instance
from marl_mrta.common.paths import package_root
from marl_mrta.env.factory import make_env

#: A result of part `solvers` for the smallest size, as an earlier run wrote it.
SOLVED_2X8 = {
    "size": "2x8", "scenario": "scenarios/lab_2r.xml", "robots": 2, "tasks": 8,
    "reference": {"time_to_optimum": 0.04, "wall_seconds": 0.04}, "cpsat": {"10": {"gap": 0.0}, "60": {"gap": 0.0}},
    "best_makespan": 48.043, "lower_bound": 48.043, "gap": 0.0,
    "methods": {m: {"makespan": 48.043, "ratio_to_best": 1.0, "peak_memory_mb": 100.0}
                for m in ("random", "ga", "auction", "exact")},
    "mappo": None, "ros": None,
}


def lab_2r_optimum():
    """The proven optimum of size 2x8 (lab_2r), on the instance bench_scale's reference solves."""
    env = make_env(package_root() / "scenarios" / "lab_2r.xml", seed=0)
    plan = solve_exact(scheduling_instance(env.scenario, env.settings.min_step, env.settings.goal_timeout))
    assert plan.proven_optimal
    return plan.makespan


def test_a_bad_part_is_one_line_and_exit_2(tmp_path, capsys):
    assert bench_scale_main(["--out", str(tmp_path), "--parts", "solvers,bogus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["bench_scale: --parts: unknown bogus"]
    assert not (tmp_path / "bench_scale.json").exists()


@pytest.mark.slow
def test_part_mappo_fine_tunes_and_keeps_the_other_figures(tmp_path):
    kept_4x8 = dict(SOLVED_2X8, size="4x8", best_makespan=25.992, lower_bound=25.992)
    (tmp_path / "bench_scale.json").write_text(json.dumps({"headline": [], "sizes": [SOLVED_2X8, kept_4x8]}))
    assert bench_scale_main(["--out", str(tmp_path), "--sizes", "2x8", "--parts", "mappo", "--mappo-seconds", "3",
                             "--mappo-set", "teacher=reference"]) == 0
    document = json.loads((tmp_path / "bench_scale.json").read_text())
    by_size = {r["size"]: r for r in document["sizes"]}
    assert by_size["4x8"] == kept_4x8                          # a size not asked for: as it was
    two = by_size["2x8"]
    assert two["methods"] == SOLVED_2X8["methods"] and two["ros"] is None   # parts not asked for: as they were
    mappo = two["mappo"]
    # The generalist is at lab_2r's optimum from the start (test_mappo_generalist), and keeps it.
    assert mappo["greedy_makespan"] == pytest.approx(lab_2r_optimum(), abs=1e-6)
    assert abs(mappo["ratio_to_best"] - 1.0) < 1e-3            # against the kept best makespan
    assert mappo["time_to_within_5pct_s"] is not None and 0 < mappo["time_to_within_5pct_s"] <= mappo["fine_tuning_s"]
    assert mappo["fine_tuning_s"] >= 3.0 and mappo["updates"] >= 1
    figures = {row["figure"] for row in document["headline"]}
    assert any(f.startswith("2x8 MAPPO (generalist + ") and "teacher=reference" in f for f in figures)
    # The setting is recorded with the figures and in the command that reproduces them.
    assert mappo["settings"] == ["teacher=reference"] and mappo["command"].endswith("--set teacher=reference")
    assert document["settings"]["mappo_settings"] == ["teacher=reference"]
    assert "4x8 ga / best known" in figures


@pytest.mark.slow
def test_part_solvers_keeps_the_settings_the_kept_mappo_figures_were_run_with(tmp_path):
    mappo_run = {"mappo_seconds": 300.0, "mappo_settings": ["teacher=reference"]}
    (tmp_path / "bench_scale.json").write_text(json.dumps({"headline": [], "sizes": [SOLVED_2X8],
                                                           "settings": mappo_run}))
    assert bench_scale_main(["--out", str(tmp_path), "--sizes", "2x8", "--parts", "solvers"]) == 0
    document = json.loads((tmp_path / "bench_scale.json").read_text())
    assert document["settings"]["mappo_seconds"] == 300.0
    assert document["settings"]["mappo_settings"] == ["teacher=reference"]
    solved = document["sizes"][0]
    assert solved["methods"]["ga"]["ratio_to_best"] == 1.0
    assert solved["best_makespan"] == pytest.approx(lab_2r_optimum(), abs=1e-6)   # solved again: the optimum
    assert solved["methods"]["random"] != SOLVED_2X8["methods"]["random"]
