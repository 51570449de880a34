"""Writes the list of dependency keys that resolve on Ubuntu 20.04 (focal) with ROS Noetic.

    python3 tools/rosdep_keys.py ROSDISTRO_CHECKOUT > test/data/rosdep_keys_noetic_focal.txt

A key is either a ROS package released into Noetic (noetic/distribution.yaml) or a system key of
rosdep/base.yaml or rosdep/python.yaml with a rule for Ubuntu focal. test/python/test_packaging.py
checks every dependency of package.xml against the list, so that `rosdep install` can resolve it.
"""
import subprocess
import sys
from pathlib import Path

import yaml

UBUNTU_RELEASE = "focal"


def resolves_on_focal(rule) -> bool:
    """One rosdep rule: {os: packages | {codename: packages | None, '*': ...} | {pip|apt: ...}}."""
    if not isinstance(rule, dict):
        return False
    if "ubuntu" not in rule:
        return "*" in rule and rule["*"] is not None
    ubuntu = rule["ubuntu"]
    if isinstance(ubuntu, list):
        return bool(ubuntu)
    if isinstance(ubuntu, dict):
        if UBUNTU_RELEASE in ubuntu:
            return ubuntu[UBUNTU_RELEASE] is not None
        if "*" in ubuntu:
            return ubuntu["*"] is not None
        # an installer rule (pip/apt/source) for every release
        return any(key in ubuntu for key in ("pip", "apt", "source", "packages"))
    return False


def system_keys(checkout: Path):
    for name in ("base.yaml", "python.yaml"):
        rules = yaml.safe_load((checkout / "rosdep" / name).read_text())
        for key, rule in rules.items():
            if resolves_on_focal(rule):
                yield key


def noetic_packages(checkout: Path):
    distribution = yaml.safe_load((checkout / "noetic" / "distribution.yaml").read_text())
    for repo_name, repo in distribution["repositories"].items():
        release = repo.get("release")
        if not release:
            continue
        yield from release.get("packages", [repo_name])


def main(argv) -> int:
    if len(argv) != 2:
        print(__doc__.strip().splitlines()[0], file=sys.stderr)
        print("usage: rosdep_keys.py ROSDISTRO_CHECKOUT", file=sys.stderr)
        return 2
    checkout = Path(argv[1])
    commit = subprocess.run(["git", "-C", str(checkout), "rev-parse", "HEAD"], capture_output=True,
                            text=True).stdout.strip() or "unknown"
    keys = sorted(set(system_keys(checkout)) | set(noetic_packages(checkout)))
    print(f"# Keys that resolve on Ubuntu {UBUNTU_RELEASE} + ROS Noetic: ros/rosdistro {commit}.")
    print("# Made by tools/rosdep_keys.py; one key a line.")
    for key in keys:
        print(key)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
