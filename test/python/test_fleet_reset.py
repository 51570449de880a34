"""The real fleet's reset drive: one robot at a time, a robot whose start pose another robot still
stands on waits, and robots that block each other's start poses drive together."""
from marl_mrta.model.fleet import reset_groups

SPACING = 0.21   # two Burger footprint radii (model/scenario.footprint_spacing)


def test_robots_drive_one_at_a_time_in_index_order_when_nothing_blocks():
    positions = [(3.0, 1.0), (3.0, 2.0), (3.0, 3.0)]
    starts = [(0.5, 0.5), (0.5, 1.5), (0.5, 2.5)]
    assert reset_groups(positions, starts, SPACING) == [[0], [1], [2]]


def test_a_robot_waits_while_another_stands_on_its_start_pose():
    # Robot 1 stands 0.1 m from robot 0's start pose: robot 1 leaves first.
    positions = [(4.0, 4.0), (0.6, 0.5)]
    starts = [(0.5, 0.5), (2.0, 2.0)]
    assert reset_groups(positions, starts, SPACING) == [[1], [0]]


def test_a_chain_of_blocked_start_poses_unwinds_from_its_free_end():
    # 1 stands on 0's start pose, 2 on 1's; 2's own start pose is free: 2 goes, then 1, then 0.
    positions = [(5.0, 5.0), (0.0, 0.05), (1.0, 0.05)]
    starts = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]
    assert reset_groups(positions, starts, SPACING) == [[2], [1], [0]]


def test_robots_blocking_each_other_in_a_cycle_drive_together_last():
    # 0 and 1 stand on each other's start poses; 2 is free and goes first.
    positions = [(1.0, 1.0), (0.0, 0.0), (3.0, 3.0)]
    starts = [(0.0, 0.0), (1.0, 1.0), (4.0, 4.0)]
    assert reset_groups(positions, starts, SPACING) == [[2], [0, 1]]


def test_a_footprint_spacing_apart_is_clear_and_closer_is_not():
    starts = [(0.0, 0.0), (5.0, 5.0)]
    assert reset_groups([(9.0, 9.0), (0.0, SPACING)], starts, SPACING) == [[0], [1]]
    assert reset_groups([(9.0, 9.0), (0.0, SPACING - 0.01)], starts, SPACING) == [[1], [0]]
