"""The Python package's layers (docs/design.md): each imports only the layers below it,
no module import closes a cycle, and no core layer reaches ROS."""
import ast
import sys
from pathlib import Path
from typing import Dict, List, Set, Tuple

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "src" / "marl_mrta"

#: Bottom to top; a layer may import its own and any lower layer. baselines and mappo share a
#: floor and may not import each other.
LAYERS: List[Tuple[str, ...]] = [
    ("common",), ("model",), ("env",), ("baselines", "mappo"), ("evaluation",), ("ros",), ("apps",),
]
CORE = {"common", "model", "env", "baselines", "mappo", "evaluation"}
#: Modules that are ROS or need it (a core importing one could not run without a ROS install).
ROS_MODULES = ("rospy", "rosgraph", "roslaunch", "rospkg.distro", "roslib", "rosservice", "rostopic", "rosnode",
               "actionlib", "actionlib_msgs", "geometry_msgs", "nav_msgs", "sensor_msgs", "std_msgs", "std_srvs",
               "visualization_msgs", "rosgraph_msgs", "move_base_msgs", "tf2_ros", "tf", "marl_mrta.msg",
               "marl_mrta.srv", "marl_mrta.ros", "marl_mrta.apps")


def _floor(layer: str) -> int:
    return next(i for i, names in enumerate(LAYERS) if layer in names)


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> Set[str]:
    """Every module a file imports, at top level or inside functions (absolute names)."""
    names: Set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                raise AssertionError(f"{path}: relative import (the layer test reads absolute names)")
            names.add(node.module)
            # `from marl_mrta.x import y` may name a module y
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def _package_modules() -> Dict[str, Path]:
    return {_module_name(path): path for path in PACKAGE.rglob("*.py")}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_module_is_in_a_layer():
    unplaced = [m for m in _package_modules() if m != "marl_mrta" and not any(_layer(m) in names for names in LAYERS)]
    assert not unplaced, f"modules outside every layer: {unplaced}"


def test_no_import_goes_up_a_layer_or_sideways_between_baselines_and_mappo():
    modules = _package_modules()
    wrong = []
    for module, path in modules.items():
        if module == "marl_mrta":
            continue
        own = _layer(module)
        for target in _imports(path):
            if not target.startswith("marl_mrta.") or target in ("marl_mrta.msg", "marl_mrta.srv") \
                    or target.startswith(("marl_mrta.msg.", "marl_mrta.srv.")):
                continue
            other = _layer(target)
            if other == own:
                continue
            if _floor(other) > _floor(own) or _floor(other) == _floor(own):
                wrong.append(f"{module} ({own}) imports {target} ({other})")
    assert not wrong, "imports against the layers:\n" + "\n".join(sorted(wrong))


def test_no_core_layer_imports_ros():
    wrong = []
    for module, path in _package_modules().items():
        if _layer(module) not in CORE:
            continue
        for target in _imports(path):
            if any(target == ros or target.startswith(ros + ".") for ros in ROS_MODULES):
                wrong.append(f"{module} imports {target}")
    assert not wrong, "core modules that reach ROS:\n" + "\n".join(sorted(wrong))


def test_module_imports_form_no_cycle():
    modules = _package_modules()
    graph = {m: sorted(t for t in _imports(p) if t in modules and t != m) for m, p in modules.items()}
    state: Dict[str, int] = {}
    stack: List[str] = []

    def visit(node: str) -> List[str]:
        state[node] = 1
        stack.append(node)
        for nxt in graph[node]:
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if state.get(nxt) is None:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return []

    for module in graph:
        if module not in state:
            cycle = visit(module)
            assert not cycle, "import cycle: " + " -> ".join(cycle)


@pytest.mark.parametrize("bad_import, expected", [
    ("from marl_mrta.ros.executor import RosExecutor\n", "imports against the layers"),
    ("import rospy\n", "core modules that reach ROS"),
])
def test_the_checks_catch_a_bad_import(tmp_path, monkeypatch, bad_import, expected):
    """The layer checks fail on a planted upward import and a planted ROS import in env/."""
    fake = tmp_path / "marl_mrta"
    for module, path in _package_modules().items():
        target = fake / path.relative_to(PACKAGE)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(path.read_text())
    (fake / "env" / "planted.py").write_text(bad_import)
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", fake)
    check = test_no_import_goes_up_a_layer_or_sideways_between_baselines_and_mappo if "layers" in expected \
        else test_no_core_layer_imports_ros
    with pytest.raises(AssertionError, match=expected):
        check()
