"""Helpers of the real-robot rostests: real.launch as a child launch on the test's master, the
robots' commands as they travel on cmd_vel, a node's process id."""
import os
import re
import shlex
import signal
import subprocess
import tempfile
import threading
import time
import xmlrpc.client

import rosgraph
import rosnode
import rospy
from geometry_msgs.msg import Twist

from marl_mrta.ros.process_group import stop_process_group

ROBOTS = ("tb3_0", "tb3_1")
README = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "README.md")


def readme_recipe(title):
    """The command lines (word lists, comments dropped) of the README's code block after the
    paragraph that starts with `title`: the tests run the recipes as written."""
    with open(README) as f:
        block = re.search(re.escape("**%s**" % title) + r".*?```bash\n(.*?)```", f.read(), re.S)
    assert block, "README.md: no recipe '%s'" % title
    return [words for words in (shlex.split(line, comments=True) for line in block.group(1).splitlines()) if words]


def start_real_launch(args, log_path, env=None):
    """`roslaunch marl_mrta real.launch ARGS` in a session of its own (stopped with its nodes)."""
    log = open(log_path, "w")
    return subprocess.Popen(["roslaunch", "marl_mrta", "real.launch", *args], stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True, env=env)


def start_in_work_dir(prefix, args):
    """real.launch ARGS writing its result into a new directory: (launch, result file, directory)."""
    work = tempfile.mkdtemp(prefix=prefix)
    out = os.path.join(work, "result.json")
    return start_real_launch(list(args) + ["out:=" + out], os.path.join(work, "launch.log")), out, work


def wait_exit(process, timeout):
    """The launch's exit code, or None (and the launch stopped) when it did not end in time."""
    try:
        return process.wait(timeout)
    except subprocess.TimeoutExpired:
        stop_process_group(process)
        return None


def node_pid(name, caller="/real_test"):
    uri = rosnode.get_api_uri(rosgraph.Master(caller), name, skip_cache=True)   # a node started anew has a new uri
    if not uri:
        return None
    code, _, pid = xmlrpc.client.ServerProxy(uri).getPid(caller)
    return pid if code == 1 else None


def interrupt_node(name):
    """What Ctrl-C does to a node of a launch: SIGINT to its process; returns the wall time."""
    pid = node_pid(name)
    assert pid, f"{name} is not running"
    os.kill(pid, signal.SIGINT)
    return time.monotonic()


def kill_node(name):
    pid = node_pid(name)
    assert pid, f"{name} is not running"
    os.kill(pid, signal.SIGKILL)
    return time.monotonic()


class Recorder:
    """(wall time, *values(msg)) of every message on a topic: by default (linear, angular) of a
    Twist or an Odometry."""

    def __init__(self, topic, kind=Twist, values=None):
        self.lock = threading.Lock()
        self.samples = []
        self.values = values or speeds
        rospy.Subscriber(topic, kind, self._on_message, queue_size=100, tcp_nodelay=True)

    def _on_message(self, msg):
        sample = (time.monotonic(), *self.values(msg))
        with self.lock:
            self.samples.append(sample)

    def after(self, since=float("-inf")):
        with self.lock:
            return [s for s in self.samples if s[0] > since]


def speeds(msg):
    twist = msg if isinstance(msg, Twist) else msg.twist.twist
    return twist.linear.x, twist.angular.z


class CommandWatch:
    """Every command on each robot's cmd_vel, as (wall time, linear, angular)."""

    def __init__(self, robots=ROBOTS):
        self.recorders = {ns: Recorder("/%s/cmd_vel" % ns) for ns in robots}

    def of(self, ns):
        return self.recorders[ns].after()

    def driving(self, since_wall):
        """Every robot was sent a moving command after `since_wall`."""
        return all(any(abs(v) > 0.05 or abs(w) > 0.2 for _, v, w in recorder.after(since_wall))
                   for recorder in self.recorders.values())

    def wait_driving(self, timeout):
        start = time.monotonic()
        deadline = start + timeout
        while time.monotonic() < deadline:
            if self.driving(start):
                return True
            time.sleep(0.05)
        return False
