"""Every result file says where it came from (common/results.py): the commit and whether the tree
had uncommitted changes, the date, the machine and the command; a benchmark run in part lists the
runs whose figures it keeps; a file already there stays whole when a new one cannot be written."""
import json
import re
import subprocess

import pytest

from marl_mrta.common import results
from marl_mrta.common.paths import package_root


def test_a_result_file_records_its_provenance(tmp_path):
    path = tmp_path / "bench_x.json"
    results.write_result(path, {"headline": [{"figure": "f", "value": 1.5}]}, command="rosrun marl_mrta bench_x")
    document = json.loads(path.read_text())
    made = document["provenance"]
    assert set(made) >= set(results.PROVENANCE_KEYS)
    head = subprocess.run(["git", "-C", str(package_root()), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    assert made["commit"] == (head or "unknown")
    assert isinstance(made["dirty"], bool) or made["dirty"] is None
    assert re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d", made["date"])
    assert made["machine"]["cores"] >= 1 and made["machine"]["cpu"]
    assert made["command"] == "rosrun marl_mrta bench_x"
    assert document["headline"][0]["value"] == 1.5


def test_a_script_of_the_package_is_named_as_a_user_runs_it():
    root = package_root()
    line = results.command_line([str(root / "scripts" / "evaluate"), "--out", str(root / "results" / "x.json")])
    assert line == "rosrun marl_mrta evaluate --out results/x.json"


def test_a_partial_run_lists_the_runs_whose_figures_it_keeps(tmp_path):
    path = tmp_path / "bench_x.json"
    results.write_result(path, {"headline": []}, command="first")
    results.write_result(path, {"headline": []}, command="second", keeps_earlier=True)
    results.write_result(path, {"headline": []}, command="third", keeps_earlier=True)
    made = json.loads(path.read_text())["provenance"]
    assert made["command"] == "third"
    assert [run["command"] for run in made["earlier"]] == ["second", "first"]
    results.write_result(path, {"headline": []}, command="whole")
    assert "earlier" not in json.loads(path.read_text())["provenance"]


def test_a_file_already_there_stays_whole_when_the_new_one_cannot_be_written(tmp_path):
    path = tmp_path / "bench_x.json"
    results.write_result(path, {"headline": [], "value": 1}, command="first")
    before = path.read_text()
    with pytest.raises(TypeError):
        results.write_result(path, {"headline": [], "value": object()})
    assert path.read_text() == before
