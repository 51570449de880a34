"""The built-in move_base out from between turtlebot3_world's pillars (bench_nav_vs_stock's drawn
leg 2 there), in lock-step: deterministic and without the stock stack. From (-0.73, 0.48) facing
south-east the robot has to back off and turn north. While the built-in used a plan in the
control cycle that made it (stock's controller takes it a cycle later), DWA reversed into the
pillar at (-1.1, 1.1) until no sample was free, and the goal was aborted with 0.52 m driven;
stock in lock-step arrives in 15.2-17.2 s (docs/guide/navigation.md)."""
import pytest

pytest.importorskip("rospkg", reason="ROS not available")
bench = pytest.importorskip("marl_mrta.apps.bench_nav_vs_stock")
from marl_mrta.evaluation.nav_comparison import MAX_RATIO_GOAL, Leg  # noqa: E402
from test_nav_corridors_turn import drive_builtin_in_lockstep  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.slow]

BETWEEN_THE_PILLARS = Leg((-0.725, 0.475, -0.9893), (0.775, 2.175, -0.1717), 1015591691)
#: s of sim time stock move_base takes in lock-step (the slower of two runs).
STOCK_LOCKSTEP_TIME = 17.2


def test_builtin_backs_out_from_between_the_pillars_as_stock_does(tmp_path):
    tb3_map = bench.map_files().get("tb3_world")
    if tb3_map is None:
        pytest.skip("TurtleBot3's turtlebot3_world map not found beside the checkout (../shared/external/...)")
    records = drive_builtin_in_lockstep(tb3_map, [BETWEEN_THE_PILLARS], tmp_path, "tb3_world")
    assert records[0].succeeded, records[0].outcome
    assert records[0].time <= MAX_RATIO_GOAL * STOCK_LOCKSTEP_TIME, f"between the pillars in {records[0].time:.1f} s"
