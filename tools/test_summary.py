"""Prints one closing line over every JUnit file catkin wrote: 'tests: N passed, N failed, N skipped'.

Exits 1 when a test failed. That includes a result file that is empty or truncated: a test node
that died before writing its results (e.g. shut down with its launch). rostest and
catkin_test_results count such a test as passed.
"""
import sys
import xml.etree.ElementTree as ET
from pathlib import Path


def count(results_dir: Path):
    passed = failed = skipped = 0
    for xml_file in sorted(results_dir.rglob("*.xml")):
        try:
            root = ET.parse(xml_file).getroot()
        except ET.ParseError:
            failed += 1  # a truncated result file means the test process died
            continue
        suites = [root] if root.tag == "testsuite" else root.iter("testsuite")
        for suite in suites:
            for case in suite.iter("testcase"):
                if case.find("failure") is not None or case.find("error") is not None:
                    failed += 1
                elif case.find("skipped") is not None:
                    skipped += 1
                else:
                    passed += 1
    return passed, failed, skipped


def main(argv) -> int:
    passed, failed, skipped = count(Path(argv[0]))
    print(f"tests: {passed} passed, {failed} failed, {skipped} skipped")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
