"""The rule by which stock move_base takes part in the simulator's lock-step
(ros/stock_lockstep.py), without ROS: on a control tick of an active goal the answer waits for
the robot's cmd_vel, between control ticks and without a goal it comes at once, a cycle without
a command is answered after the wait, and a goal's result counts on the tick of its stamp."""
import pytest

from marl_mrta.ros.stock_lockstep import StockLockstepRule

RATE = 20.0     # physics ticks per s
PERIOD = 0.1    # move_base at 10 Hz: every other tick


def rule(**kwargs):
    return StockLockstepRule(PERIOD, RATE, command_wait=kwargs.get("command_wait", 0.5), result_wait=0.05,
                             idle_wait=kwargs.get("idle_wait", 0.0))


def commanded_on_tick_2():
    """A rule whose goal came on tick 0 and whose first command answered tick 2."""
    r = rule()
    tick(r, 0)
    r.on_goal()
    r.on_tick(2, 2 / RATE, 0.0)
    r.on_command(is_zero=False)
    assert r.answer(0.0).cmd_vel_count == 1
    return r


def tick(r, index, wall=0.0):
    r.on_tick(index, index / RATE, wall)
    return r.answer(wall)


def test_without_a_goal_every_tick_is_needed_and_answered_after_the_idle_wait():
    r = rule(idle_wait=0.005)
    for index in range(5):
        r.on_tick(index, index / RATE, float(index))
        assert r.answer(index + 0.004) is None    # move_base's costmap threads get wall time
        assert r.wait_left(index + 0.004) == pytest.approx(0.001)
        answer = r.answer(index + 0.005)
        assert answer is not None and answer.tick == index
        assert answer.next_stamp == 0.0 and answer.cmd_vel_count == 0 and answer.goal_end_tick == 0
    r.on_tick(5, 5 / RATE, 10.0)
    r.on_goal()                                   # a goal during the wait: answered at once
    assert r.answer(10.0).next_stamp == pytest.approx(7 / RATE, abs=1e-5)


def test_a_control_tick_waits_for_the_command_and_the_ticks_between_are_skipped():
    r = rule()
    tick(r, 10)
    r.on_goal()                                   # accepted on tick 10: the first command is due on tick 12
    answer = tick(r, 11)
    assert answer is not None and answer.next_stamp == pytest.approx(12 / RATE, abs=1e-5)
    r.on_tick(12, 12 / RATE, 0.0)
    assert r.answer(0.1) is None                  # held: move_base has not answered yet
    assert r.wait_left(0.1) == pytest.approx(0.4)
    r.on_command(is_zero=False)
    answer = r.answer(0.2)
    assert answer.tick == 12 and answer.cmd_vel_count == 1
    assert answer.next_stamp == pytest.approx(14 / RATE, abs=1e-5)   # tick 13 runs through
    assert r.timeouts == 0
    r.on_tick(13, 13 / RATE, 0.3)                 # re-sent between control ticks: at once
    assert r.answer(0.3).next_stamp == pytest.approx(14 / RATE, abs=1e-5)
    r.on_tick(14, 14 / RATE, 0.4)
    assert r.answer(0.4) is None                  # the command of tick 12 does not answer tick 14
    r.on_command(is_zero=False)
    assert r.answer(0.41).cmd_vel_count == 2


def test_a_command_that_comes_before_the_tick_between_answers_the_next_control_tick():
    """The simulator runs through tick 3 without this answer (next_stamp) and publishes tick 4,
    on which move_base commands at once; tick 3's message may reach the node after that command.
    The command answers tick 4. Before, tick 3's answer took it, and tick 4 and tick 5 each
    waited command_wait (0.5 s of wall time) for a command that had come already."""
    r = commanded_on_tick_2()
    r.on_command(is_zero=False, stamp=4 / RATE)   # tick 4's command, before tick 3's message
    answer = tick(r, 3)
    assert answer is not None and answer.next_stamp == pytest.approx(4 / RATE, abs=1e-5)
    answer = tick(r, 4)
    assert answer is not None and answer.tick == 4 and answer.cmd_vel_count == 2
    assert answer.next_stamp == pytest.approx(6 / RATE, abs=1e-5) and r.timeouts == 0
    r.on_tick(6, 6 / RATE, 1.0)
    assert r.answer(1.0) is None                  # tick 6 waits for a command of its own


def test_a_second_command_of_the_same_cycle_does_not_answer_the_next_control_tick():
    """move_base stops the robot and commands again in one cycle (an oscillation's stop): the
    second command was sent on tick 2, which the first answered; tick 4 waits for its own."""
    r = commanded_on_tick_2()
    r.on_command(is_zero=True, stamp=2 / RATE)
    tick(r, 3)
    r.on_tick(4, 4 / RATE, 0.0)
    assert r.answer(0.0) is None
    r.on_command(is_zero=False, stamp=4 / RATE)
    assert r.answer(0.01).tick == 4


def test_a_cycle_without_a_command_is_answered_after_the_wait_then_every_tick_is_watched():
    r = rule(command_wait=0.5)
    tick(r, 0)
    r.on_goal()
    r.on_tick(2, 2 / RATE, 10.0)
    assert r.answer(10.49) is None
    answer = r.answer(10.5)                       # move_base planned on this cycle: no command
    assert answer is not None and answer.next_stamp == 0.0 and r.timeouts == 1
    r.on_tick(3, 3 / RATE, 11.0)
    assert r.answer(11.0) is None                 # the next command may come on any tick now
    r.on_command(is_zero=False)
    assert r.answer(11.01).next_stamp == pytest.approx(5 / RATE, abs=1e-5)


def test_a_move_base_without_a_path_is_not_waited_for_until_it_commands_or_plans():
    """No path to the goal (navfn publishes the empty plan): move_base plans again and clears its
    costmaps, sending no command, until a recovery behaviour turns the robot. Each tick then
    waited the full command_wait (sim time at a tenth of its pace); after one missed control tick
    they are answered at once. A goal's first plan is still waited for, however long it takes."""
    r = rule(command_wait=0.5)
    tick(r, 0)
    r.on_goal()
    wall = 10.0
    for index in (2, 3, 4, 5):                    # no plan yet (a loaded machine): each waited for
        r.on_tick(index, index / RATE, wall)
        assert r.answer(wall) is None
        wall += 0.5
        assert r.answer(wall).tick == index
    assert r.timeouts == 4 and not r.quiet
    r.on_plan(empty=True)                         # the planner found no path
    assert r.quiet
    for index in range(6, 30):                    # answered at once
        r.on_tick(index, index / RATE, wall)
        answer = r.answer(wall)
        assert answer is not None and answer.next_stamp == 0.0
    assert r.timeouts == 4
    r.on_command(is_zero=False)                   # a recovery behaviour turns the robot
    assert not r.quiet
    assert tick(r, 30, wall).next_stamp == pytest.approx(31 / RATE, abs=1e-5)
    r.on_tick(31, 31 / RATE, wall)
    assert r.answer(wall) is None                 # its commands are waited for again
    r.on_command(is_zero=False)
    assert r.answer(wall).cmd_vel_count == 2
    r.on_tick(33, 33 / RATE, wall)                # the turn is over, still no path: one miss, then quiet
    assert r.answer(wall + 0.5) is not None and r.quiet
    r.on_plan(empty=False)                        # a path at last: the controller's ticks are waited for
    assert not r.quiet
    r.on_tick(34, 34 / RATE, wall)
    assert r.answer(wall) is None
    r.on_result(34 / RATE)
    r.on_goal()                                   # a new goal starts with a clean slate
    r.on_plan(empty=True)
    assert not r.quiet


def test_a_result_counts_on_the_tick_of_its_stamp_and_ends_the_waiting():
    r = rule()
    tick(r, 0)
    r.on_goal()
    r.on_tick(2, 2 / RATE, 0.0)
    r.on_command(is_zero=True)                    # move_base stops the robot, then sends the result
    assert r.answer(0.01) is None                 # the result is awaited briefly
    r.on_result(2 / RATE)
    answer = r.answer(0.02)
    assert answer.goal_end_tick == 2 and answer.next_stamp == 0.0 and answer.cmd_vel_count == 1
    assert tick(r, 3).next_stamp == 0.0           # no goal: every tick again
    r.on_goal()
    r.on_tick(5, 5 / RATE, 1.0)
    r.on_command(is_zero=True)                    # a stop without a result (DWA found no path)
    assert r.answer(1.01) is None
    assert r.answer(1.06).goal_end_tick == 2      # answered after the result wait


def test_a_goal_replacing_a_running_one_keeps_the_control_phase():
    r = commanded_on_tick_2()
    tick(r, 3)
    r.on_goal()                                   # preempts on tick 3: move_base's loop keeps its phase
    assert tick(r, 3).next_stamp == pytest.approx(4 / RATE, abs=1e-5)
    r.on_tick(4, 4 / RATE, 0.0)
    assert r.answer(0.0) is None


def test_a_re_sent_tick_counts_what_came_since():
    r = commanded_on_tick_2()
    r.on_command(is_zero=False)                   # a recovery behaviour's second command
    r.on_tick(2, 2 / RATE, 0.6)
    assert r.answer(0.6).cmd_vel_count == 2


def test_bad_settings_are_refused():
    with pytest.raises(ValueError):
        StockLockstepRule(0.0, RATE)
    with pytest.raises(ValueError):
        StockLockstepRule(PERIOD, RATE, command_wait=-1.0)


def test_with_a_particle_filter_each_answer_waits_for_its_transform_of_the_latest_scan():
    r = StockLockstepRule(PERIOD, RATE, command_wait=0.5, result_wait=0.05, idle_wait=0.0,
                          localization_tolerance=0.5)
    r.on_tick(0, 0.0, 0.0, scan_stamp=0.0)
    assert r.answer(0.0) is not None              # no scan and no transform yet: nothing to wait for
    r.on_localization(0.5)                        # amcl answered the scan of 0.0 s (post-dated 0.5 s)
    r.on_tick(4, 4 / RATE, 1.0, scan_stamp=4 / RATE)
    assert r.answer(1.0) is None                  # the scan of tick 4 is not answered yet
    assert r.wait_left(1.0) == pytest.approx(0.5)
    r.on_localization(4 / RATE + 0.5)
    assert r.answer(1.01).tick == 4
    r.on_tick(5, 5 / RATE, 2.0, scan_stamp=4 / RATE)
    assert r.answer(2.0).tick == 5                # no new scan since
    r.on_tick(8, 8 / RATE, 3.0, scan_stamp=8 / RATE)
    assert r.answer(3.49) is None
    assert r.answer(3.5).tick == 8                # a filter that does not answer holds a tick at most command_wait
