"""fleet: a live fleet's requests from a shell, through the task manager's services
(docs/guide/live_fleet.md).

    rosrun marl_mrta fleet submit ID CATEGORY X Y [--yaw RAD] [--service-time S] [--after ID ...]
    rosrun marl_mrta fleet submit --file TASKS.yaml        # several at once: a list of {id, category, x, y, yaw, service_time, after}
    rosrun marl_mrta fleet cancel ID
    rosrun marl_mrta fleet leave ROBOT [--reason TEXT]
    rosrun marl_mrta fleet join ROBOT
    rosrun marl_mrta fleet status

Every command takes `--manager` (default /rl_task_allocation_manager) and `--timeout` (wall s to
wait for the manager). Exit status 0 when the manager did it (its one line on stdout), 1 when it
refused or is not there (one line on stderr), 2 on a usage error. Every check of a request is the
task manager's; this command only carries it.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, List, Optional, Sequence, Tuple

import yaml

DEFAULT_MANAGER = "/rl_task_allocation_manager"
#: Keys of a task in a --file, and their meaning.
TASK_KEYS = {"id": "its id", "category": "its category", "x": "m", "y": "m", "yaw": "rad (default 0)",
             "service_time": "s (default 0)", "after": "ids of its predecessors (default none)"}


class UsageError(ValueError):
    """A command line or task file this command cannot read; str(error) is one line."""


@dataclass(frozen=True)
class TaskLine:
    """One task to submit, as the manager's marl_mrta/TaskRequest carries it."""

    id: str
    category: str
    x: float
    y: float
    yaw: float = 0.0
    service_time: float = 0.0
    predecessors: Tuple[str, ...] = ()


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:   # one line, exit status 2 (argparse's own prints the usage too)
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="fleet", description="A live fleet's requests, through the task manager's services.")
    parser.add_argument("--manager", default=DEFAULT_MANAGER, help=f"the task manager node (default {DEFAULT_MANAGER})")
    parser.add_argument("--timeout", type=float, default=10.0, help="wall s to wait for the manager (default 10)")
    commands = parser.add_subparsers(dest="command", metavar="submit|cancel|leave|join|status", parser_class=_Parser)
    submit = commands.add_parser("submit", help="add tasks to the running episode")
    submit.add_argument("task", nargs="*", metavar="ID CATEGORY X Y", help="one task: id, category, goal x and y (m)")
    submit.add_argument("--yaw", type=float, default=0.0, help="goal heading (rad, default 0)")
    submit.add_argument("--service-time", type=float, default=0.0, help="s at the goal (default 0)")
    submit.add_argument("--after", nargs="+", default=[], metavar="ID", help="its predecessors")
    submit.add_argument("--file", type=Path, help="a YAML list of tasks instead: " +
                        ", ".join(f"{k} ({v})" for k, v in TASK_KEYS.items()))
    cancel = commands.add_parser("cancel", help="drop a task before its service starts")
    cancel.add_argument("id")
    leave = commands.add_parser("leave", help="take a robot out of the fleet")
    leave.add_argument("robot")
    leave.add_argument("--reason", default="operator", help="kept in the record (default operator)")
    join = commands.add_parser("join", help="bring a robot that left back")
    join.add_argument("robot")
    commands.add_parser("status", help="print the schedule as it stands (~fleet_status)")
    return parser


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    args = build_parser().parse_args(list(argv))
    if args.command is None:
        raise UsageError("give a command: submit, cancel, leave, join or status")
    if not (args.timeout > 0 and math.isfinite(args.timeout)):
        raise UsageError(f"--timeout: must be a positive number of seconds, got {args.timeout:g}")
    if args.command == "submit":
        args.tasks = submit_tasks(args)
    return args


def _number(text: Any, what: str) -> float:
    if isinstance(text, bool):
        raise UsageError(f"{what}: expected a number, got {text!r}")
    try:
        return float(text)
    except (TypeError, ValueError):
        raise UsageError(f"{what}: expected a number, got {text!r}") from None


def submit_tasks(args: argparse.Namespace) -> List[TaskLine]:
    """The tasks of `fleet submit`: one from the command line, or those of --file."""
    if args.file is not None:
        if args.task or args.after or args.yaw != 0.0 or args.service_time != 0.0:
            raise UsageError("submit: give either one task on the command line or --file, not both")
        return read_task_file(args.file)
    if len(args.task) != 4:
        raise UsageError(f"submit: expected ID CATEGORY X Y, got {len(args.task)} value(s) (or --file TASKS.yaml)")
    task_id, category, x, y = args.task
    return [TaskLine(task_id, category, _number(x, "submit: X"), _number(y, "submit: Y"), args.yaw, args.service_time,
                     tuple(args.after))]


def read_task_file(path: Path) -> List[TaskLine]:
    """A YAML list of tasks (TASK_KEYS); UsageError naming the file, the task and the key."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as error:
        raise UsageError(f"{path}: cannot read ({error.strerror})") from None
    except yaml.YAMLError as error:
        raise UsageError(f"{path}: not YAML ({str(error).splitlines()[0]})") from None
    if not isinstance(data, list) or not data:
        raise UsageError(f"{path}: expected a list of tasks, each with {', '.join(TASK_KEYS)}")
    tasks = []
    for k, entry in enumerate(data, 1):
        where = f"{path}: task {k}"
        if not isinstance(entry, dict):
            raise UsageError(f"{where}: expected a mapping with {', '.join(TASK_KEYS)}")
        unknown = sorted(set(map(str, entry)) - set(TASK_KEYS))
        if unknown:
            raise UsageError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(TASK_KEYS)})")
        missing = [key for key in ("id", "category", "x", "y") if key not in entry]
        if missing:
            raise UsageError(f"{where}: missing {missing[0]!r}")
        after = entry.get("after", [])
        if isinstance(after, str):
            after = [after]
        if not isinstance(after, list) or not all(isinstance(a, (str, int)) for a in after):
            raise UsageError(f"{where}: 'after': expected a list of task ids")
        tasks.append(TaskLine(str(entry["id"]), str(entry["category"]), _number(entry["x"], f"{where}: 'x'"),
                              _number(entry["y"], f"{where}: 'y'"), _number(entry.get("yaw", 0.0), f"{where}: 'yaw'"),
                              _number(entry.get("service_time", 0.0), f"{where}: 'service_time'"),
                              tuple(str(a) for a in after)))
    return tasks


# ---------------------------------------------------------------------------------------- ROS

def _call(args: argparse.Namespace) -> Tuple[bool, str]:
    """(ok, message) of the request; (False, why) when the manager is not there."""
    import rospy
    from marl_mrta import srv
    from marl_mrta.msg import TaskRequest

    name, kind, request = {
        "submit": ("submit_tasks", srv.SubmitTasks,
                   lambda: [[TaskRequest(t.id, t.category, t.x, t.y, t.yaw, t.service_time, list(t.predecessors))
                             for t in args.tasks]]),
        "cancel": ("cancel_task", srv.CancelTask, lambda: [args.id]),
        "leave": ("robot_leave", srv.RobotLeave, lambda: [args.robot, args.reason]),
        "join": ("robot_join", srv.RobotJoin, lambda: [args.robot]),
    }[args.command]
    service = args.manager.rstrip("/") + "/" + name
    proxy = rospy.ServiceProxy(service, kind)
    try:
        proxy.wait_for_service(timeout=args.timeout)
        response = proxy(*request())
    except rospy.ROSException:
        return False, f"{service}: not available within {args.timeout:g} s (is the task manager running?)"
    except (rospy.ServiceException, OSError) as error:
        return False, f"{service}: {str(error).splitlines()[0]}"
    return bool(response.ok), response.message


def _status(args: argparse.Namespace) -> Tuple[bool, str]:
    import rospy
    from marl_mrta.msg import FleetStatus
    from marl_mrta.ros.conversions import snapshot_from_message
    from marl_mrta.ros.fleet_status import describe

    rospy.init_node("fleet_cli", anonymous=True, disable_signals=True)
    topic = args.manager.rstrip("/") + "/fleet_status"
    try:
        msg = rospy.wait_for_message(topic, FleetStatus, timeout=args.timeout)
    except rospy.ROSException:
        return False, f"{topic}: nothing within {args.timeout:g} s (is the task manager running?)"
    head = f"{args.manager}: allocator {msg.allocator}, episode {msg.episode}: "
    lines = describe(snapshot_from_message(msg))
    return True, head + "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = [a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a]   # roslaunch remappings
    try:
        args = parse_args(argv)
    except UsageError as error:
        print(f"fleet: {error}", file=sys.stderr)
        return 2
    try:
        ok, message = _status(args) if args.command == "status" else _call(args)
    except KeyboardInterrupt:
        print("fleet: interrupted", file=sys.stderr)
        return 130
    try:
        print(message, file=sys.stdout if ok else sys.stderr)
    except BrokenPipeError:   # `fleet status | head`: the rest goes nowhere, quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0 if ok else 1
