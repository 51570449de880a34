"""The built-in move_base out of the doors map's dead-end pocket (bench_nav_vs_stock's fixed doors
legs), in lock-step: deterministic and without the stock stack. Out of the pocket the robot passes
close under the pocket's wall end, where DWA's choice between a little forward and a little
backward flips with every 6 mm. While move_base's periodic re-plans reset DWA's oscillation flags,
that dither went on until "Robot is oscillating" aborted the goal after about 60 s; stock leaves
the pocket in 28-31 s at rtf 1 (docs/guide/navigation.md)."""
import pytest

pytest.importorskip("rospkg", reason="ROS not available")
bench = pytest.importorskip("marl_mrta.apps.bench_nav_vs_stock")
from marl_mrta.evaluation.nav_comparison import MAX_RATIO_GOAL  # noqa: E402
from test_nav_corridors_turn import drive_builtin_in_lockstep  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.slow]

#: s of sim time stock move_base takes out of the pocket at rtf 1 (the slowest of three drives).
STOCK_POCKET_EXIT = 31.4


def test_builtin_leaves_the_dead_end_pocket_without_dithering(tmp_path):
    into, out_of = drive_builtin_in_lockstep(bench.map_files()["doors"], list(bench.FIXED_LEGS["doors"]), tmp_path, "doors")
    assert into.succeeded, into.outcome
    assert out_of.succeeded, out_of.outcome
    assert out_of.time <= MAX_RATIO_GOAL * STOCK_POCKET_EXIT, f"out of the pocket in {out_of.time:.1f} s"
