"""The evaluation command's ros executor option: bad combinations are one line and exit 2, the
default output name says the executor, roslaunch's remapping arguments are ignored."""
from pathlib import Path

from marl_mrta.apps.evaluate import main, parse_args

ROOT = Path(__file__).resolve().parents[2]


def test_profile_is_refused_with_the_ros_executor(capsys):
    assert main(["--method", "exact", "--executor", "ros", "--profile", "measured_tb3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "evaluate: --profile: noise profiles belong to the embedded executor (the simulator has its own)"


def test_roslaunch_remappings_are_ignored():
    args = parse_args(["--method", "exact", "--executor", "ros", "__name:=evaluate", "__log:=/tmp/x.log"])
    assert args.executor == "ros" and args.methods == ["exact"] and args.scenario is None


def test_embedded_default_output_name_is_unchanged(tmp_path, monkeypatch):
    import marl_mrta.apps.evaluate as cli
    monkeypatch.setattr(cli, "runs_dir", lambda: tmp_path / "results" / "runs")   # a user's runs: results/runs/
    assert main(["--method", "exact", "--episodes", "1", "--quiet", "--no-both-references",
                 "--scenario", str(ROOT / "scenarios" / "lab_2r.xml")]) == 0
    assert (tmp_path / "results" / "runs" / "evaluate_lab_2r_exact.json").is_file()
