"""Prints one closing line over every JUnit file catkin wrote: 'tests: N passed, N failed, N skipped'.

Exits 1 when a test failed. That includes a result file that is empty or truncated: a test node
that died before writing its results (e.g. shut down with its launch). rostest and
catkin_test_results count such a test as passed.

Skipped tests are listed first, one line each with the reason, then failed ones, each with the
first line of what failed (the closing lines are what a CI log shows of a long run). A rostest
writes two files: the test node's (rosunit-NAME.xml, its test cases) and rostest's own (one case,
testNAME: the node ran and wrote results). When every case of the node's file is skipped,
rostest's case counts as skipped too, not as passed.
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path


def _cases(root):
    suites = [root] if root.tag == "testsuite" else root.iter("testsuite")
    for suite in suites:
        yield from suite.iter("testcase")


def _what_failed(problem):
    """The first line of a failure: pytest writes it as the message, rosunit before the traceback."""
    for text in (problem.get("message"), problem.text):
        lines = [line.strip() for line in (text or "").splitlines() if line.strip()]
        if lines:
            return lines[0][:300]
    return problem.get("type") or ""


def count(results_dir: Path, skip_lines=None, failure_lines=None):
    passed = failed = skipped = 0
    documents = []
    for xml_file in sorted(results_dir.rglob("*.xml")):
        try:
            documents.append((xml_file, ET.parse(xml_file).getroot()))
        except ET.ParseError:
            failed += 1  # a truncated result file means the test process died
            if failure_lines is not None:
                failure_lines.append(f"failed: {xml_file.name}: the result file is empty or truncated (the test died)")
    skipped_nodes = set()
    for xml_file, root in documents:
        cases = list(_cases(root))
        if xml_file.name.startswith("rosunit-") and cases and all(c.find("skipped") is not None for c in cases):
            skipped_nodes.add(xml_file.stem[len("rosunit-"):])
    for xml_file, root in documents:
        rostest_file = xml_file.name.startswith("rostest-")
        for case in _cases(root):
            problem = next((found for found in (case.find("failure"), case.find("error")) if found is not None), None)
            if problem is not None:
                failed += 1
                if failure_lines is not None:
                    what = _what_failed(problem)
                    line = f"failed: {xml_file.name}: {case.get('name', '')}"
                    failure_lines.append(line + (f": {what}" if what else ""))
            elif case.find("skipped") is not None:
                skipped += 1
                if skip_lines is not None:
                    reason = case.find("skipped").get("message") or (case.find("skipped").text or "").strip()
                    skip_lines.append("skipped: " + case.get("name", "") + (": " + reason.splitlines()[0] if reason else ""))
            elif rostest_file and case.get("name", "").startswith("test") and case.get("name")[4:] in skipped_nodes:
                skipped += 1
            else:
                passed += 1
    return passed, failed, skipped


def main(argv) -> int:
    skip_lines, failure_lines = [], []
    passed, failed, skipped = count(Path(argv[0]), skip_lines, failure_lines)
    for line in skip_lines + failure_lines:
        print(line)
    print(f"tests: {passed} passed, {failed} failed, {skipped} skipped")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
