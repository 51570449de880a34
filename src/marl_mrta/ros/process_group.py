"""Stopping a child started in a session of its own (roslaunch, Xvfb) with everything it started."""
from __future__ import annotations

import os
import signal
import subprocess


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
