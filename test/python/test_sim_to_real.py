"""The sim-to-real figures without ROS (evaluation/sim_to_real.py) and real.launch's fleet and
robot checks (ros/launch_args.py)."""
import math

import pytest

from marl_mrta.common.paths import package_root
from marl_mrta.evaluation.sim_to_real import (localisation_errors, motion_latencies, pose_at, read_ground_truth,
                                              stop_time, summary)
from marl_mrta.ros.launch_args import fleet_value, read_fleet, real_robots


def test_stop_time_is_the_first_zero_after_which_every_command_is_zero():
    commands = [(0.0, 0.2, 0.0), (0.1, 0.2, 0.1), (0.2, 0.0, 0.0), (0.25, 0.15, 0.0), (0.3, 0.0, 0.0), (0.4, 0.0, 0.0)]
    assert stop_time(commands, 0.0) == 0.3
    assert stop_time(commands, 0.35) == 0.4
    assert stop_time(commands[:4], 0.0) is None   # still moving at the end


def test_motion_latency_counts_from_a_command_that_starts_a_standing_robot():
    commands = [(1.0, 0.0, 0.0), (2.0, 0.2, 0.0), (2.1, 0.2, 0.0), (5.0, 0.0, 0.0), (6.0, 0.0, 1.0)]
    odometry = [(t / 10.0, 0.0, 0.0) for t in range(0, 21)] + [(2.05, 0.0, 0.0), (2.12, 0.02, 0.0), (2.2, 0.1, 0.0)] \
        + [(5.5, 0.0, 0.0), (6.04, 0.0, 0.0), (6.09, 0.0, 0.3)]
    odometry.sort()
    assert motion_latencies(commands, odometry) == pytest.approx([0.12, 0.09])


def test_ground_truth_is_interpolated_between_records(tmp_path):
    path = tmp_path / "stand_in.csv"
    path.write_text("kind,stamp,robot,x,y,yaw,linear,angular,other\n"
                    "pose,10.0,tb3_0,1.0,2.0,3.1,0.2,0.0,\n"
                    "pose,10.1,tb3_0,1.2,2.0,-3.1,0.2,0.0,\n"
                    "contact,10.05,tb3_0,1.1,2.1,,,,wall\n")
    tracks = read_ground_truth([path])
    x, y, yaw = pose_at(tracks["tb3_0"], 10.05)
    assert (x, y) == pytest.approx((1.1, 2.0))
    assert abs(abs(yaw) - math.pi) < 0.05          # across +-pi, not through 0
    assert pose_at(tracks["tb3_0"], 9.0) is None
    errors = localisation_errors([(10.05, 1.1, 2.3, yaw)], tracks["tb3_0"])
    assert errors[0] == pytest.approx((0.3, 0.0), abs=1e-9)
    assert summary([0.3, 0.1, 0.2])["median"] == 0.2 and summary([])["count"] == 0


def test_the_example_fleet_reads_and_names_every_robot():
    fleet = read_fleet(str(package_root() / "config" / "fleet_example.yaml"))
    assert sorted(fleet) == ["tb3_0", "tb3_1"] and fleet["tb3_0"]["ssh_port"] == 22


@pytest.mark.parametrize("text, message", [
    ("tb3_0:\n  address: 1.2.3.4\n  user: u\n", "tb3_0.env_loader: missing value"),
    ("tb3_0:\n  address: 1.2.3.4\n  user: u\n  env_loader: /e\n  port: 22\n", "tb3_0.port: unknown key"),
    ("tb3_0:\n  address: 1.2.3.4\n  user: u\n  env_loader: /e\n  ssh_port: 0\n", "tb3_0.ssh_port: must be >= 1, got 0"),
])
def test_a_bad_fleet_file_is_one_line(tmp_path, text, message):
    path = tmp_path / "fleet.yaml"
    path.write_text(text)
    with pytest.raises(ValueError) as error:
        fleet_value(str(path), "tb3_0", "address")
    assert str(error.value) == f"fleet: {path}: {message}"


def test_real_launch_robots_must_be_the_scenarios():
    scenario = str(package_root() / "scenarios" / "lab_2r.xml")
    assert real_robots("tb3_0 tb3_1", scenario) == "tb3_0 tb3_1"
    with pytest.raises(ValueError, match="are not the robots of"):
        real_robots("tb3_1 tb3_0", scenario)


def test_a_report_row_takes_evaluates_document_and_the_recordings(tmp_path):
    from marl_mrta.evaluation.sim_to_real import row_figures
    summary_ = {"makespan_mean": 64.2, "complete_pct": 100.0, "logic_consistent_pct": 100.0,
                "allocation": [["A1", "A2"], ["A3", "A4"]]}
    result = {"results": [{"summary": summary_, "episodes": [{}], "seconds": 70.0,
                           "representative_episode": {"abort_reason": ""}}]}
    # tb3_0 stands, is sent moving at 1.0 and its odometry moves at 1.08; amcl 0.1 m off the truth.
    probe = {"tb3_0": {"cmd_vel": [[0.5, 0.0, 0.0], [1.0, 0.2, 0.0]],
                       "odom": [[0.9, 0.0, 0.0], [1.04, 0.0, 0.0], [1.08, 0.1, 0.0]],
                       "amcl_pose": [[1.05, 1.1, 2.0, 0.0]]},
             "tb3_1": {"cmd_vel": [], "odom": [], "amcl_pose": []}}
    tracks = {"tb3_0": [(1.0, 1.0, 2.0, 0.0), (1.1, 1.0, 2.0, 0.0)]}
    row = row_figures("stand_in", {"result": result, "probe": probe, "ground_truth": tracks})
    assert row["makespan"] == 64.2 and row["wall_seconds"] == 70.0 and row["allocation"] == [["A1", "A2"], ["A3", "A4"]]
    assert row["command_to_motion_s"]["median"] == pytest.approx(0.08)
    assert row["localisation_error_m"]["max"] == pytest.approx(0.1)
    assert row["localisation"] == "amcl vs the stand-in's ground truth"


@pytest.mark.parametrize("name, value", [("method", "exakt"), ("method", "exact,policy"), ("stand_in_processes", "two"),
                                         ("nav", ""), ("reset", "now"), ("reset_drive", "all")])
def test_a_bad_choice_of_real_launch_is_one_line(name, value):
    from marl_mrta.ros.launch_args import real_choices
    assert real_choices(method="exact,ga", stand_in_processes="per_robot", nav="auto", reset="current", reset_drive="together")
    with pytest.raises(ValueError) as error:
        real_choices(**{name: value})
    assert str(error.value).startswith(f"real.launch: {name}:='{value}': must be one of ")


def test_the_fault_runs_end_with_the_one_that_kills_the_master():
    """The fault runs share one master, which the master-lost run kills: any kind after it would
    find no master, and every kind says where its latency counts from."""
    from marl_mrta.apps.sim_to_real import MEASURED_FROM, parse_args
    from marl_mrta.evaluation.sim_to_real import FAULTS
    assert FAULTS[-1] == "master_lost"
    assert set(MEASURED_FROM) == set(FAULTS)
    assert parse_args(["--faults", "manager_hung,estop"]).faults == "manager_hung,estop"
