"""bench_mappo --ros bookkeeping that needs no ROS graph: how results merge into bench_mappo.json
and how a bad option is refused."""
import json

from marl_mrta.apps import bench_mappo as bench
from marl_mrta.apps.bench_mappo_ros import merge_into


def ros_section(**modes):
    return {"arenas": 2, "target_s": 48.93, "exact_in_ros": {"makespan_s": 46.6}, **modes}


def test_a_mode_not_run_keeps_its_last_result(tmp_path):
    path = tmp_path / "bench_mappo.json"
    embedded_row = {"figure": "time to policy, embedded, lab_2r", "value": 0.9, "unit": "s", "goal": "<= 60"}
    path.write_text(json.dumps({"headline": [embedded_row], "embedded_part": 1}))
    scratch = {"time_to_policy_s": None, "cap_minutes": 20.0, "steps_per_s": 0.5, "target_s": 49.6}
    merge_into(path, ros_section(scratch=scratch))

    document = merge_into(path, ros_section(pretrained={"time_to_policy_s": 61.5, "target_s": 48.93}))

    assert document["ros"]["scratch"] == scratch           # kept, with its own target
    assert document["ros"]["pretrained"]["time_to_policy_s"] == 61.5
    assert document["embedded_part"] == 1                  # the embedded figures are kept
    values = {row["figure"]: row["value"] for row in document["headline"]}
    assert values["time to policy, embedded, lab_2r"] == 0.9
    assert any("from scratch" in figure and value == "> 1200" for figure, value in values.items())
    assert any("candidates" in figure and value == 61.5 for figure, value in values.items())


def test_an_embedded_run_keeps_the_ros_figures(tmp_path):
    path = tmp_path / "bench_mappo.json"
    merge_into(path, ros_section(scratch={"time_to_policy_s": 145.1, "cap_minutes": 15.0, "steps_per_s": 3.7}))
    embedded_row = {"figure": "time to policy, embedded, lab_2r (median, sequential)", "value": 0.9, "unit": "s",
                    "goal": "<= 60"}
    bench.write_embedded_figures(path, {"time_to_policy": {"median_s": 0.9}, "headline": [embedded_row]})

    document = json.loads(path.read_text())
    assert document["time_to_policy"] == {"median_s": 0.9}
    assert document["ros"]["scratch"]["time_to_policy_s"] == 145.1
    values = {row["figure"]: row["value"] for row in document["headline"]}
    assert values["time to policy, embedded, lab_2r (median, sequential)"] == 0.9
    assert any("from scratch" in figure and value == 145.1 for figure, value in values.items())


def test_a_rerun_mode_replaces_its_old_result(tmp_path):
    path = tmp_path / "bench_mappo.json"
    merge_into(path, ros_section(pretrained={"time_to_policy_s": 900.0}))
    document = merge_into(path, ros_section(pretrained={"time_to_policy_s": 60.0}))
    assert document["ros"]["pretrained"]["time_to_policy_s"] == 60.0
    assert [row["value"] for row in document["headline"] if "candidates" in row["figure"]] == [60.0]


def test_no_pretraining_candidates_is_one_line_and_exit_2(tmp_path, capsys):
    code = bench.main(["--ros", "--pretrain-seeds", "0", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == ["bench_mappo: --pretrain-seeds: 0: must be at least 1"]
    assert not (tmp_path / "bench_mappo.json").exists()
