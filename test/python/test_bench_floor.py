"""bench_floor's floors are the ones it names: each scenario 16 robots x 32 tasks, on the lab, a
60 x 60 m floor of rooms and the 30 x 50 m warehouse at 0.03 m (not a drawn team on a drawn map)."""
import pytest

from marl_mrta.apps.bench_floor import ROBOTS, TASKS, floor_scenarios
from marl_mrta.model.occupancy_map import load_map
from marl_mrta.model.scenario import load_scenario

pytestmark = pytest.mark.slow


def test_each_floor_is_the_size_it_is_named_for(tmp_path):
    sizes = {}
    for name, path in floor_scenarios(tmp_path).items():
        scenario = load_scenario(path)
        assert (scenario.n_robots, scenario.n_tasks) == (ROBOTS, TASKS), name
        grid = load_map(scenario.map_path)
        sizes[name] = (grid.width * grid.resolution, grid.height * grid.resolution, grid.resolution)
    assert sizes["lab"][0] < 10.0
    assert min(sizes["rooms_60x60"][:2]) >= 60.0 and sizes["rooms_60x60"][2] == pytest.approx(0.05)
    assert sizes["warehouse_30x50"] == pytest.approx((30.0, 50.0, 0.03), abs=0.02)   # whole cells
