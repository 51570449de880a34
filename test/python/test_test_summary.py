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
    assert capsys.readouterr().out.strip().splitlines() == ["skipped: b", "tests: 1 passed, 0 failed, 1 skipped"]


def test_an_empty_result_file_is_a_failure(tmp_path, capsys):
    # A test node shut down before writing its results leaves an empty file, which rostest and
    # catkin_test_results count as a pass.
    (tmp_path / "ok.xml").write_text(PASSED)
    (tmp_path / "rosunit-died.xml").write_text("")
    assert test_summary.main([str(tmp_path)]) == 1
    assert capsys.readouterr().out.strip().splitlines()[-1] == "tests: 1 passed, 1 failed, 1 skipped"


def test_a_failed_case_is_a_failure(tmp_path):
    (tmp_path / "bad.xml").write_text('<testsuite><testcase name="a"><failure message="x"/></testcase></testsuite>')
    assert test_summary.main([str(tmp_path)]) == 1


def test_a_rostest_whose_node_skipped_every_case_counts_as_skipped(tmp_path, capsys):
    # rostest's own file has one case per test node ("it ran and wrote results"), which passes
    # even when the node skipped everything; the node's file carries the skip and its reason.
    (tmp_path / "rosunit-nav_stock.xml").write_text(
        '<testsuite><testcase name="test_tour"><skipped message="stock navigation not available"/></testcase></testsuite>')
    (tmp_path / "rostest-test_rostest_nav_stock.xml").write_text(
        '<testsuite><testcase classname="rostest.runner.RosTest" name="testnav_stock"/></testsuite>')
    (tmp_path / "rosunit-nav_tour.xml").write_text('<testsuite><testcase name="test_tour"/></testsuite>')
    (tmp_path / "rostest-test_rostest_nav_tour.xml").write_text(
        '<testsuite><testcase classname="rostest.runner.RosTest" name="testnav_tour"/></testsuite>')
    assert test_summary.main([str(tmp_path)]) == 0
    assert capsys.readouterr().out.strip().splitlines() == [
        "skipped: test_tour: stock navigation not available", "tests: 2 passed, 0 failed, 2 skipped"]


def test_each_failure_is_named_with_what_failed_before_the_closing_line(tmp_path, capsys):
    # The closing lines are what a CI log keeps of a long run: they must say which test failed and why.
    (tmp_path / "rosunit-nav_stock.xml").write_text(
        '<testsuite><testcase name="test_tour"><failure type="AssertionError">0.18 not less than or equal to 0.17 : '
        'goal A4 reached 0.180 rad off\n  File "nav_stock_test.py", line 66</failure></testcase></testsuite>')
    (tmp_path / "pytest-python.xml").write_text(
        '<testsuite><testcase name="test_probes"><failure message="assert 5 == 4">trace</failure></testcase>'
        '<testcase name="test_ok"/></testsuite>')
    (tmp_path / "rosunit-died.xml").write_text("")
    assert test_summary.main([str(tmp_path)]) == 1
    assert capsys.readouterr().out.strip().splitlines() == [
        "failed: rosunit-died.xml: the result file is empty or truncated (the test died)",
        "failed: pytest-python.xml: test_probes: assert 5 == 4",
        "failed: rosunit-nav_stock.xml: test_tour: 0.18 not less than or equal to 0.17 : goal A4 reached 0.180 rad off",
        "tests: 1 passed, 3 failed, 0 skipped"]
