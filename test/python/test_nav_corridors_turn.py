"""The built-in move_base round a wall end of the corridors map (bench_nav_vs_stock's drawn leg 2
there), in lock-step: deterministic and without the stock stack. The robot reverses along the
bottom corridor and turns round the wall end at (5.0, 1.0) into the corridor above. While the
built-in navfn put its path points on cell centres, half a cell north-east of stock navfn's (cell
corners), DWA turned early, stood under the wall end and timed out at 120 s; stock in lock-step
reaches the goal in 49-55 s (docs/guide/navigation.md)."""
import pytest

pytest.importorskip("rospkg", reason="ROS not available")
bench = pytest.importorskip("marl_mrta.apps.bench_nav_vs_stock")
from marl_mrta.evaluation.nav_comparison import MAX_RATIO_GOAL, Leg  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROUND_THE_WALL_END = Leg((1.575, 0.525, 2.5385), (0.325, 1.675, -1.1669), 600763903)
#: s of sim time stock move_base takes in lock-step (the slowest of four runs).
STOCK_LOCKSTEP_TIME = 54.8


def drive_builtin_in_lockstep(map_path, legs, tmp_path, tag):
    """The built-in stack drives each leg once on the map, in lock-step (the simulator's ideal
    profile, localisation from the simulator); the legs' records, in order."""
    records, error = bench.run_stack("builtin", map_path, legs, 1, "simulator", "ideal", rtf=0.0, goal_timeout=120.0,
                                     workdir=str(tmp_path), tag=tag, lockstep=True)
    assert error == ""
    assert [r.index for r in records] == list(range(len(legs)))
    return records


def test_builtin_turns_round_the_wall_end_as_stock_does(tmp_path):
    records = drive_builtin_in_lockstep(bench.map_files()["corridors"], [ROUND_THE_WALL_END], tmp_path, "corridors")
    assert records[0].succeeded, records[0].outcome
    assert records[0].time <= MAX_RATIO_GOAL * STOCK_LOCKSTEP_TIME, f"round the wall end in {records[0].time:.1f} s"
