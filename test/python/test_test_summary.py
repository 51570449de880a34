"""tools/test_summary.py: the closing line of `make test`, and its exit status."""
import importlib.util
from pathlib import Path

spec = importlib.util.spec_from_file_location("test_summary", Path(__file__).resolve().parents[2] / "tools" / "test_summary.py")
test_summary = importlib.util.module_from_spec(spec)
spec.loader.exec_module(test_summary)

PASSED = '<testsuite tests="2"><testcase name="a"/><testcase name="b"><skipped/></testcase></testsuite>'


def test_passing_results_exit_0(tmp_path, capsys):
    (tmp_path / "ok.xml").write_text(PASSED)
    assert test_summary.main([str(tmp_path)]) == 0
    assert capsys.readouterr().out.strip() == "tests: 1 passed, 0 failed, 1 skipped"


def test_an_empty_result_file_is_a_failure(tmp_path, capsys):
    # A test node shut down before writing its results leaves an empty file, which rostest and
    # catkin_test_results count as a pass.
    (tmp_path / "ok.xml").write_text(PASSED)
    (tmp_path / "rosunit-died.xml").write_text("")
    assert test_summary.main([str(tmp_path)]) == 1
    assert capsys.readouterr().out.strip() == "tests: 1 passed, 1 failed, 1 skipped"


def test_a_failed_case_is_a_failure(tmp_path):
    (tmp_path / "bad.xml").write_text('<testsuite><testcase name="a"><failure message="x"/></testcase></testsuite>')
    assert test_summary.main([str(tmp_path)]) == 1
