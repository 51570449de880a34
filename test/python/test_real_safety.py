"""The safety rules of real robots (ros/safety.py, no ROS): when a silent robot, a lost master or
an outside fault stops the fleet, which reason is kept, and when a stop can be cleared; when a
robot's cmd_vel gate lets its navigation drive it."""
import pytest

from marl_mrta.ros.safety import PARTS, SafetyLimits, SafetyMonitor, VelocityGate, hold_times

LIMITS = SafetyLimits(odom_silent_after=0.5, scan_silent_after=1.0, move_base_silent_after=2.0, master_lost_after=0.5)


def monitor_heard_everything(now=0.0):
    monitor = SafetyMonitor(["tb3_0", "tb3_1"], LIMITS)
    for robot in range(2):
        for part in PARTS:
            monitor.heard(robot, part, now)
    monitor.master_answered(now)
    monitor.rearm(now)
    return monitor


def test_nothing_is_wrong_while_every_part_talks():
    monitor = monitor_heard_everything()
    for t in (0.1, 0.2, 0.3, 0.4):
        for robot in range(2):
            for part in PARTS:
                monitor.heard(robot, part, t)
        monitor.master_answered(t)
        assert monitor.check(t + 0.05) == ""
    assert not monitor.tripped


@pytest.mark.parametrize("part, limit", [("odom", 0.5), ("scan", 1.0), ("move_base", 2.0)])
def test_a_silent_part_stops_the_fleet_after_its_limit_naming_robot_and_part(part, limit):
    monitor = monitor_heard_everything()
    quiet_robot = 1
    t = 0.0
    while t < limit + 0.5:
        t = round(t + 0.05, 2)
        for robot in range(2):
            for other in PARTS:
                if robot != quiet_robot or other != part:
                    monitor.heard(robot, other, t)
        monitor.master_answered(t)
        reason = monitor.check(t)
        if reason:
            break
    assert reason == f"tb3_1: {part} silent for {t:.1f} s"
    assert limit < t <= limit + 0.05 + 1e-9


def test_a_lost_master_stops_the_fleet_with_the_last_error():
    monitor = monitor_heard_everything()
    for robot in range(2):
        for part in PARTS:
            monitor.heard(robot, part, 0.6)
    monitor.master_failed("http://localhost:11311: [Errno 111] Connection refused")
    assert monitor.check(0.4) == ""
    assert monitor.check(0.6) == ("ROS master unreachable for 0.6 s "
                                  "(http://localhost:11311: [Errno 111] Connection refused)")


def test_the_first_reason_stays_until_a_reset_rearms():
    monitor = monitor_heard_everything()
    assert monitor.trip("e-stop (~estop)", 0.1)
    assert not monitor.trip("tb3_0: odom silent for 0.6 s", 0.6)
    assert monitor.check(5.0) == "e-stop (~estop)"
    assert monitor.tripped_at == 0.1
    # Everything talks again: the reset clears the stop.
    for robot in range(2):
        for part in PARTS:
            monitor.heard(robot, part, 5.0)
    monitor.master_answered(5.0)
    assert monitor.rearm(5.0) == "" and not monitor.tripped


def test_a_fault_that_persists_trips_again_at_the_rearm():
    monitor = monitor_heard_everything()
    monitor.trip("tb3_1: scan silent for 1.0 s", 1.0)
    for part in PARTS:
        monitor.heard(0, part, 3.0)
    monitor.master_answered(3.0)
    assert monitor.rearm(3.0).startswith("tb3_1: odom silent for 3.0 s")
    assert monitor.tripped


def test_parts_never_heard_are_missing_and_count_from_the_arming():
    monitor = SafetyMonitor(["tb3_0"], LIMITS)
    assert monitor.missing() == ["tb3_0 odom", "tb3_0 scan", "tb3_0 move_base"]
    assert monitor.fault(100.0) == ""          # not armed: start-up waits with missing()
    monitor.heard(0, "scan", 10.0)
    monitor.heard(0, "move_base", 10.0)
    monitor.rearm(10.0)
    assert monitor.fault(10.4) == ""
    assert monitor.fault(10.6) == "tb3_0: odom silent for 0.6 s"


def test_a_stop_sends_zero_at_once_then_holds_it():
    assert hold_times(2.0, 1.0, 0.1) == pytest.approx([2.0 + 0.1 * k for k in range(11)])
    assert hold_times(2.0, 0.0, 0.1) == [2.0]


def test_the_gate_is_closed_until_the_first_permit_and_opens_once():
    gate = VelocityGate(permit_timeout=1.0)
    assert gate.update(0.0) == (False, "")
    assert gate.reason == "no drive permit yet"
    gate.permit(True, 0.1)
    assert gate.update(0.1) == (True, "open")
    assert gate.update(0.2) == (True, "")
    assert gate.is_open and gate.reason == ""


def test_a_withdrawn_permit_closes_the_gate_at_once_and_a_new_one_opens_it():
    gate = VelocityGate(permit_timeout=1.0)
    gate.permit(True, 0.0)
    gate.update(0.0)
    gate.permit(False, 0.05)
    is_open, change = gate.update(0.05)
    assert not is_open and change == "drive permit withdrawn (the fleet is stopped)"
    assert gate.permit_withdrawn
    assert gate.update(0.1) == (False, "")   # said once
    gate.permit(True, 2.0)
    assert gate.update(2.0) == (True, "open")


def test_a_permit_older_than_the_timeout_closes_the_gate():
    gate = VelocityGate(permit_timeout=1.0)
    gate.permit(True, 0.0)
    assert gate.update(1.0)[0]                # exactly the timeout: still open
    is_open, change = gate.update(1.25)
    assert not is_open
    assert change == "no drive permit for 1.2 s (the task manager is gone or hangs)"
    assert not gate.permit_withdrawn
    assert gate.reason == change


@pytest.mark.parametrize("timeout", [0.0, -1.0, float("nan")])
def test_a_gate_needs_a_positive_timeout(timeout):
    with pytest.raises(ValueError, match="permit_timeout: must be > 0"):
        VelocityGate(timeout)
