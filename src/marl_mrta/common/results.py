"""Result files: every JSON document the package writes under results/ says where it came from.

`write_result` adds a `provenance` object (the one place it is made) and writes atomically:
- `commit`: the checkout's git commit ("unknown" outside a git checkout);
- `dirty`: whether tracked files other than results/ had uncommitted changes;
- `date`: UTC, ISO 8601;
- `machine`: CPU model, logical cores, operating system;
- `command`: the command line that made it, with the package's own paths made relative.
docs/results.md and the README's table are generated from these files (tools/results_doc.py).
"""
from __future__ import annotations

import datetime
import json
import os
import platform
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any, Dict, Optional, Sequence

from marl_mrta.common.paths import package_root

PROVENANCE_KEYS = ("commit", "dirty", "date", "machine", "command")


def json_value(value: Any) -> Any:
    """json.dumps' `default` for result documents: numpy scalars and paths. (Non-finite floats are
    written as JSON's common extension, Infinity and NaN, which Python's json reads back.)"""
    if hasattr(value, "item"):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _git(root: Path, *args: str) -> Optional[str]:
    try:
        done = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout if done.returncode == 0 else None


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def machine() -> Dict[str, Any]:
    return {"cpu": cpu_model(), "cores": os.cpu_count() or 0,
            "os": f"{platform.system()} {platform.release()}", "python": platform.python_version()}


def command_line(argv: Optional[Sequence[str]] = None) -> str:
    """The command as a user would type it: a script of the package as `rosrun marl_mrta NAME`,
    the package's own absolute paths relative to its root."""
    argv = list(sys.argv if argv is None else argv)
    root = str(package_root())
    if argv:
        exe = Path(argv[0]).name
        if exe.endswith(".py") and argv[0].startswith(root):
            argv[0] = os.path.relpath(argv[0], root)
        elif (package_root() / "scripts" / exe).is_file():
            argv[:1] = ["rosrun", "marl_mrta", exe]
    words = [word.replace(root + "/", "").replace(root, ".") for word in argv]
    return " ".join(shlex.quote(word) for word in words)


def provenance(command: Optional[str] = None) -> Dict[str, Any]:
    root = package_root()
    commit = (_git(root, "rev-parse", "HEAD") or "").strip() or "unknown"
    status = _git(root, "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results")
    return {"commit": commit, "dirty": bool(status and status.strip()) if status is not None else None,
            "date": datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat(),
            "machine": machine(), "command": command if command is not None else command_line()}


def write_result(path: Path, document: Dict[str, Any], command: Optional[str] = None, indent: int = 1,
                 keeps_earlier: bool = False) -> None:
    """The JSON result file with its provenance, written atomically (a kill never leaves half a
    file, and a file already there stays whole until the new one is complete). With
    `keeps_earlier` (a benchmark run in part, keeping the other figures of the file already at
    `path`), the provenance lists the earlier runs' under `earlier`, newest first."""
    path = Path(path)
    document = dict(document)
    document.pop("provenance", None)
    made = provenance(command)
    if keeps_earlier and path.is_file():
        try:
            before = json.loads(path.read_text()).get("provenance")
        except (ValueError, AttributeError):
            before = None
        if isinstance(before, dict):
            made["earlier"] = [{k: v for k, v in before.items() if k != "earlier"}] + list(before.get("earlier", []))
    document["provenance"] = made
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(document, indent=indent, default=json_value, allow_nan=True))
    tmp.replace(path)
