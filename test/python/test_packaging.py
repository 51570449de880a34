"""The package installs as a ROS user expects on Ubuntu 20.04 + Noetic, checked statically here
(the machine that runs the tests may be another): package.xml format 3 with dependency keys that
rosdep resolves on focal, pip-only packages in requirements.txt alone, Python that runs on 3.8,
ROS Noetic's environment sourced by the Makefile, and the licence package.xml names."""
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
KEYS_FILE = ROOT / "test" / "data" / "rosdep_keys_noetic_focal.txt"
DEPEND_TAGS = ("depend", "build_depend", "build_export_depend", "exec_depend", "test_depend", "buildtool_depend",
               "doc_depend")
PIP_ONLY = {"torch", "ortools", "tensorboard", "pandas", "xacro", "pytest-xdist", "pyflakes", "vermin"}
PYTHON_SOURCES = ("src/marl_mrta", "scripts", "tools", "test/python", "test/nodes", "setup.py")


def manifest():
    return ET.parse(ROOT / "package.xml").getroot()


def test_package_xml_is_format_3_with_urls_and_its_licence_file():
    root = manifest()
    assert root.get("format") == "3"
    assert {url.get("type") for url in root.findall("url")} >= {"website", "repository", "bugtracker"}
    licence = root.find("license")
    assert licence.text == "Apache-2.0" and (ROOT / licence.get("file", "LICENSE")).is_file()
    assert "Apache License" in (ROOT / "LICENSE").read_text() and "Version 2.0" in (ROOT / "LICENSE").read_text()


def test_every_dependency_is_a_rosdep_key_on_focal():
    known = {line.strip() for line in KEYS_FILE.read_text().splitlines() if line.strip() and not line.startswith("#")}
    assert len(known) > 1000   # the list is whole, not the package's own keys alone
    keys = [(dep.tag, dep.text.strip()) for tag in DEPEND_TAGS for dep in manifest().findall(tag)]
    unknown = [f"<{tag}>{key}</{tag}>" for tag, key in keys if key not in known]
    assert keys and not unknown, f"not rosdep keys on Ubuntu focal + Noetic ({KEYS_FILE.name}): {unknown}"


def test_pip_only_packages_are_in_requirements_alone():
    keys = [dep.text.strip() for tag in DEPEND_TAGS for dep in manifest().findall(tag)]
    assert not [key for key in keys if key.endswith("-pip")]
    required = {re.split(r"[<>=;\s]", line.strip())[0].lower() for line in (ROOT / "requirements.txt").read_text().splitlines()
                if line.strip() and not line.startswith("#")}
    assert PIP_ONLY - {"torch"} <= required
    assert "torch" not in required   # the bootstrap chooses its build (CPU index or PyPI)


def test_the_venv_carries_scipy_and_matplotlib_of_its_own_numpy_on_python_3_8():
    """focal's scipy 1.3 and matplotlib 3.1 predate the numpy that pandas (OR-Tools) pulls in."""
    lines = (ROOT / "requirements.txt").read_text().splitlines()
    for name in ("scipy", "matplotlib"):
        assert any(line.startswith(name) and 'python_version < "3.9"' in line for line in lines), name


def test_python_runs_on_3_8():
    vermin = shutil.which("vermin") or str(Path(sys.executable).with_name("vermin"))
    if not Path(vermin).exists():
        pytest.skip("vermin is not installed (make setup installs it from requirements.txt)")
    sources = [str(ROOT / p) for p in PYTHON_SOURCES] + [str(p) for p in (ROOT / "scripts").iterdir()]
    done = subprocess.run([vermin, "-q", "--no-tips", "--violations", "-t=3.8-", "--eval-annotations",
                           "--backport", "dataclasses", *sources], capture_output=True, text=True)
    assert done.returncode == 0, "needs a Python newer than 3.8 (Noetic's):\n" + done.stdout + done.stderr


def test_the_makefile_sources_ros_noetic_where_it_is_installed(tmp_path):
    setup = tmp_path / "setup.bash"
    setup.write_text("")
    with_noetic = subprocess.run(["make", "-n", "-C", str(ROOT), "build", f"ROS_DISTRO_SETUP={setup}", "WS=/nonexistent"],
                                 capture_output=True, text=True).stdout
    without = subprocess.run(["make", "-n", "-C", str(ROOT), "build", f"ROS_DISTRO_SETUP={tmp_path / 'absent'}",
                              "WS=/nonexistent"], capture_output=True, text=True).stdout
    assert f"source {setup} &&" in with_noetic and "catkin_make" in with_noetic
    assert "source " + str(tmp_path / "absent") not in without


def test_the_bootstrap_says_where_torch_came_from():
    script = (ROOT / "tools" / "bootstrap.sh").read_text()
    assert "https://download.pytorch.org/whl/cpu" in script
    assert re.search(r'echo "bootstrap: \$torch_spec from \$source_of_torch', script)
