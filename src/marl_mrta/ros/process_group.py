"""Children started in a session of their own (roslaunch, Xvfb): a free port for a private master, and
stopping a child with everything it started."""
from __future__ import annotations

import os
import signal
import socket
import subprocess


def free_port() -> int:
    """A TCP port free on this machine now (for `roslaunch -p`, so that runs do not meet)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_process_group(process: subprocess.Popen, timeout: float = 30.0) -> None:
    """SIGINT to the process group (what Ctrl-C does to roslaunch, which then stops its nodes),
    SIGKILL if it is still there after `timeout` s."""
    if process.poll() is not None:
        return
    os.killpg(process.pid, signal.SIGINT)
    try:
        process.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
