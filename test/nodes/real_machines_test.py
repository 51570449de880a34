#!/usr/bin/env python3
"""rostest: real.launch fleet:=FILE starts each robot's side through roslaunch's <machine> tags.

The test runs an SSH server of its own on 127.0.0.1 (a free port, host and user keys in a temp
dir, a HOME whose ~/.ssh knows both) and logs in as a user of its own (roslaunch starts a machine
on this host with the launching user itself, without SSH), writes a fleet file naming it for tb3_0
and tb3_1 with an env-loader script that records its calls, and starts real.launch stand_in:=true
stand_in_processes:=per_robot fleet:=FILE. It checks that both stand-in processes run under a
remote roslaunch started through sshd, and that the task manager hears both robots (it becomes
ready, waiting for the operator's go). Where no sshd can run (openssh-server missing:
tools/bootstrap.sh installs it, or paramiko missing), the test is skipped with one line.
"""
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import unittest
from pathlib import Path

import importlib.util

import rosgraph
import rospy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from nav_goals_test import rosrun_marking_skips  # noqa: E402
from real_test_helpers import ROBOTS, node_pid, start_real_launch, wait_exit  # noqa: E402

from marl_mrta.ros.process_group import free_port, stop_process_group  # noqa: E402

MANAGER = "/rl_task_allocation_manager"
FLEET_USER = "marl_mrta_fleet"   # the robots' login: another user than the launching one
# System tools live in sbin, which a user's PATH need not hold.
SBIN_PATH = os.pathsep.join([os.environ.get("PATH", ""), "/usr/local/sbin", "/usr/sbin", "/sbin"])


def system_tool(name):
    return shutil.which(name, path=SBIN_PATH)


SSHD = system_tool("sshd")


def unavailable():
    if SSHD is None or shutil.which("ssh-keygen") is None:
        return "no sshd to test roslaunch's machine tags against (openssh-server: tools/bootstrap.sh installs it)"
    if importlib.util.find_spec("paramiko") is None:   # roslaunch's SSH client
        return "roslaunch cannot use SSH: python3-paramiko is not installed (tools/bootstrap.sh installs it)"
    if os.geteuid() != 0 and not user_exists(FLEET_USER):
        return "no second user to log in as over SSH (run as root, or create the user %s)" % FLEET_USER
    return ""


def user_exists(name):
    return subprocess.run(["id", "-u", name], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0


def ensure_fleet_user():
    """The user the robots' side logs in as: created once (no password, not locked, so that sshd
    takes its key without PAM)."""
    if not user_exists(FLEET_USER):
        subprocess.run([system_tool("useradd") or "useradd", "--system", "--no-create-home", "--home-dir", "/nonexistent", "--shell", "/bin/bash",
                        FLEET_USER], check=True)
    if os.geteuid() == 0:
        subprocess.run([system_tool("usermod") or "usermod", "-p", "*", FLEET_USER], check=True)


def ancestors(pid):
    """Command names of a process's parents, nearest first."""
    names = []
    while pid > 1:
        status = Path("/proc/%d/status" % pid).read_text()
        pid = int(next(line.split()[1] for line in status.splitlines() if line.startswith("PPid:")))
        if pid > 1:
            names.append(Path("/proc/%d/comm" % pid).read_text().strip())
    return names


class RealMachinesTest(unittest.TestCase):
    def setUp(self):
        reason = unavailable()
        if reason:
            self.skipTest(reason)
        self.work = Path(tempfile.mkdtemp(prefix="real_machines_"))
        self.work.chmod(0o755)   # the fleet user reads its env loader here
        self.sshd = None

    def tearDown(self):
        if self.sshd is not None:
            self.sshd.terminate()
            self.sshd.wait(10)

    def start_sshd(self):
        home = self.work / "home"
        (home / ".ssh").mkdir(parents=True)
        os.chmod(home / ".ssh", 0o700)
        for key in (self.work / "host_key", home / ".ssh" / "id_ed25519"):
            subprocess.run(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", str(key)], check=True)
        # sshd reads the keys as the fleet user: outside the launching user's private ~/.ssh.
        authorized = self.work / "authorized_keys"
        shutil.copy(home / ".ssh" / "id_ed25519.pub", authorized)
        authorized.chmod(0o644)
        port = free_port()
        config = self.work / "sshd_config"
        config.write_text("\n".join([
            "Port %d" % port, "ListenAddress 127.0.0.1", "HostKey %s" % (self.work / "host_key"),
            "AuthorizedKeysFile %s" % authorized, "PidFile %s" % (self.work / "sshd.pid"),
            "StrictModes no", "PasswordAuthentication no", "KbdInteractiveAuthentication no", "UsePAM no",
            "PermitRootLogin prohibit-password", "PubkeyAuthentication yes", ""]))
        Path("/run/sshd").mkdir(exist_ok=True)   # sshd's privilege separation directory
        self.sshd = subprocess.Popen([SSHD, "-D", "-e", "-f", str(config)], stdout=subprocess.DEVNULL,
                                     stderr=open(self.work / "sshd.log", "w"))
        deadline = time.monotonic() + 10.0
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), 0.5).close()
                break
            except OSError:
                if self.sshd.poll() is not None or time.monotonic() > deadline:
                    self.skipTest("sshd cannot run here: " + (self.work / "sshd.log").read_text().strip().splitlines()[-1:][0])
                time.sleep(0.1)
        host_key = (self.work / "host_key.pub").read_text().split()
        # roslaunch looks the bare address up before it connects (remoteprocess.ssh_check_known_hosts),
        # paramiko then the [address]:port it connects to: known_hosts needs both.
        (home / ".ssh" / "known_hosts").write_text("127.0.0.1 %s %s\n[127.0.0.1]:%d %s %s\n"
                                                   % (host_key[0], host_key[1], port, host_key[0], host_key[1]))
        (home / ".ssh" / "config").write_text("Host 127.0.0.1\n  IdentityFile %s\n" % (home / ".ssh" / "id_ed25519"))
        return home, port

    def write_fleet(self, port):
        """A fleet of two machines on 127.0.0.1: an env loader of its own per robot, as each robot
        has its own (roslaunch starts one remote roslaunch per distinct machine configuration)."""
        calls = self.work / "env_loader.calls"
        calls.touch()
        calls.chmod(0o666)
        setup = Path(os.environ.get("CMAKE_PREFIX_PATH", "").split(":")[0]) / "setup.bash"
        (self.work / "ros_remote").mkdir(mode=0o777)
        (self.work / "ros_remote").chmod(0o777)
        entries = []
        for ns in ROBOTS:
            loader = self.work / ("env_loader_%s.sh" % ns)
            loader.write_text("\n".join([
                "#!/bin/bash", "echo \"%s $$ $*\" >> %s" % (ns, calls),
                "source %s" % setup, "export ROS_MASTER_URI=%s" % rosgraph.get_master_uri(),
                "export PATH=%s" % os.environ["PATH"], "export ROS_HOME=%s" % (self.work / "ros_remote"),
                "exec \"$@\"", ""]))
            loader.chmod(0o755)
            entries.append("%s:\n  address: 127.0.0.1\n  user: %s\n  env_loader: %s\n  ssh_port: %d\n"
                           % (ns, FLEET_USER, loader, port))
        fleet = self.work / "fleet.yaml"
        fleet.write_text("".join(entries))
        return fleet, calls

    def test_the_robot_side_starts_through_machine_tags(self):
        rospy.init_node("real_test")
        ensure_fleet_user()
        home, port = self.start_sshd()
        fleet, calls = self.write_fleet(port)
        env = dict(os.environ, HOME=str(home), ROS_HOME=str(self.work / "ros_home"))
        launch = start_real_launch(["stand_in:=true", "stand_in_processes:=per_robot", "fleet:=%s" % fleet,
                                    "method:=exact", "episodes:=1", "go:=false", "nav:=builtin",
                                    "out:=%s" % (self.work / "result.json")], self.work / "launch.log", env=env)
        try:
            deadline = time.monotonic() + 240.0
            while not rospy.has_param(MANAGER + "/env"):   # set once it heard both robots and their amcl
                if launch.poll() is not None or time.monotonic() > deadline:
                    self.fail("the task manager did not come up:\n" + (self.work / "launch.log").read_text()[-3000:])
                time.sleep(0.5)
            started = sorted(line.split()[0] for line in calls.read_text().splitlines())
            self.assertEqual(started, sorted(ROBOTS), "one remote roslaunch per robot's machine")
            for ns in ROBOTS:
                pid = node_pid("/%s/turtlebot3_stand_in" % ns)
                self.assertIsNotNone(pid)
                self.assertIn("sshd", ancestors(pid), "%s's stand-in was not started over SSH" % ns)
        finally:
            stop_process_group(launch)
            wait_exit(launch, 30.0)


if __name__ == "__main__":
    rosrun_marking_skips("real_machines", RealMachinesTest, sys.argv)
