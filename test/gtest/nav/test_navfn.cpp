// Global planner on hand-made grids: safety, length against the exact 8-connected shortest
// path, failures, tolerance and path variability.
#include <gtest/gtest.h>

#include <cmath>
#include <queue>
#include <set>

#include "marl_mrta/nav/inflation_layer.h"
#include "marl_mrta/nav/navfn_planner.h"
#include "marl_mrta/nav/static_layer.h"
#include "nav_test_helpers.h"

using namespace marl_mrta::nav;
using namespace marl_mrta::nav::testing;

namespace {

std::unique_ptr<LayeredCostmap> costmapOf(const marl_mrta::map::OccupancyMap& m, double inflation_radius = 1.0,
                                          double scaling = 3.0) {
  auto costmap = std::make_unique<LayeredCostmap>(false, false);
  costmap->setFootprint(padFootprint(burgerFootprint(), 0.01));
  auto layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, *costmap);
  layer->setMap(m);
  costmap->addLayer(std::move(layer));
  costmap->addLayer(std::make_unique<InflationLayer>("inflation_layer", InflationLayerConfig{inflation_radius, scaling, false}));
  costmap->updateMap(Pose2D{});
  return costmap;
}

// Exact shortest 8-connected path length [m] through cells below the inscribed cost.
double shortest8Connected(const CostGrid& g, const Pose2D& start, const Pose2D& goal) {
  unsigned sx, sy, gx, gy;
  g.worldToMap(start.x, start.y, sx, sy);
  g.worldToMap(goal.x, goal.y, gx, gy);
  std::vector<double> dist(g.cells().size(), 1e18);
  using Item = std::pair<double, unsigned>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  dist[g.index(sx, sy)] = 0.0;
  open.push({0.0, g.index(sx, sy)});
  while (!open.empty()) {
    const auto [d, i] = open.top();
    open.pop();
    if (d > dist[i]) continue;
    const int x = i % g.sizeX(), y = i / g.sizeX();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx == 0 && dy == 0) || !g.inBounds(x + dx, y + dy)) continue;
        const unsigned j = g.index(x + dx, y + dy);
        if (g.cells()[j] >= 253) continue;
        const double nd = d + ((dx != 0 && dy != 0) ? std::sqrt(2.0) : 1.0);
        if (nd < dist[j]) {
          dist[j] = nd;
          open.push({nd, j});
        }
      }
    }
  }
  return dist[g.index(gx, gy)] * g.resolution();
}

void expectPathSafe(const CostGrid& g, const PlanResult& plan) {
  for (const Pose2D& p : plan.path) {
    unsigned mx, my;
    ASSERT_TRUE(g.worldToMap(p.x, p.y, mx, my));
    ASSERT_LT(g.cost(mx, my), 253) << "path point (" << p.x << ", " << p.y << ") in a lethal/inscribed cell";
  }
}

// 3 m x 2 m room with a wall across it, open at one end, and a pillar.
marl_mrta::map::OccupancyMap wallRoom() { return roomMap(60, 40, {{28, 0, 31, 30}, {10, 10, 14, 14}}); }

}  // namespace

TEST(Navfn, TraversalCostTransform) {
  EXPECT_EQ(50, NavfnPlanner::traversalCost(0, true));
  EXPECT_EQ(50 + static_cast<int>(0.8f * 100), NavfnPlanner::traversalCost(100, true));
  EXPECT_EQ(251, NavfnPlanner::traversalCost(252, true));
  EXPECT_EQ(254, NavfnPlanner::traversalCost(253, true));
  EXPECT_EQ(254, NavfnPlanner::traversalCost(254, true));
  EXPECT_EQ(253, NavfnPlanner::traversalCost(255, true));
  EXPECT_EQ(254, NavfnPlanner::traversalCost(255, false));
}

TEST(Navfn, PathAvoidsLethalAndInscribedCellsWithTurtlebotInflation) {
  auto costmap = costmapOf(wallRoom());
  NavfnPlanner planner{NavfnConfig{}};
  for (const auto& [start, goal] : std::vector<std::pair<Pose2D, Pose2D>>{
           {{0.3, 0.3, 0}, {2.7, 0.3, 0}}, {{0.3, 1.7, 0}, {2.7, 0.5, 1.0}}, {{2.5, 1.0, 0}, {0.3, 0.3, 0}}}) {
    const PlanResult plan = planner.makePlan(costmap->costmap(), start, goal);
    ASSERT_TRUE(plan.ok()) << plan.message;
    expectPathSafe(costmap->costmap(), plan);
    EXPECT_NEAR(start.x, plan.path.front().x, 0.05);
    EXPECT_DOUBLE_EQ(goal.x, plan.path.back().x);
    EXPECT_DOUBLE_EQ(goal.yaw, plan.path.back().yaw);
    // The path goes around the wall's open end (y > 1.5 m).
    double max_y = 0.0;
    for (const Pose2D& p : plan.path) max_y = std::max(max_y, p.y);
    EXPECT_GT(max_y, 1.5);
  }
}

TEST(Navfn, PathPointsSitOnCellCornersAsStockNavfnPlacesThem) {
  // navfn_ros converts the traced cell coordinates as origin + index x resolution: the path's
  // first point is the corner of the start's cell, not its centre. DWA follows this path, and
  // half a cell decides which side of a wall end it swings (docs/guide/navigation.md).
  auto costmap = costmapOf(wallRoom());
  const CostGrid& grid = costmap->costmap();
  NavfnPlanner planner{NavfnConfig{}};
  const Pose2D start{0.33, 0.31, 0.0}, goal{2.7, 0.3, 0.0};
  const PlanResult plan = planner.makePlan(grid, start, goal);
  ASSERT_TRUE(plan.ok()) << plan.message;
  unsigned sx, sy;
  ASSERT_TRUE(grid.worldToMap(start.x, start.y, sx, sy));
  EXPECT_NEAR(grid.originX() + sx * grid.resolution(), plan.path.front().x, 1e-6);
  EXPECT_NEAR(grid.originY() + sy * grid.resolution(), plan.path.front().y, 1e-6);
}

TEST(Navfn, LengthWithinTenPercentOfExact8ConnectedPath) {
  auto costmap = costmapOf(wallRoom(), 0.15, 3.0);
  NavfnPlanner planner{NavfnConfig{}};
  const std::vector<std::pair<Pose2D, Pose2D>> cases{
      {{0.3, 0.3, 0}, {2.7, 0.3, 0}}, {{0.2, 1.8, 0}, {2.8, 0.2, 0}}, {{0.3, 0.3, 0}, {1.2, 1.8, 0}},
      {{2.2, 1.0, 0}, {0.9, 0.4, 0}}, {{0.3, 1.0, 0}, {1.1, 1.0, 0}}};
  for (const auto& [start, goal] : cases) {
    const PlanResult plan = planner.makePlan(costmap->costmap(), start, goal);
    ASSERT_TRUE(plan.ok()) << plan.message;
    expectPathSafe(costmap->costmap(), plan);
    const double exact = shortest8Connected(costmap->costmap(), start, goal);
    const double length = pathLength(plan.path);
    EXPECT_NEAR(length, exact, 0.1 * exact) << "from (" << start.x << ", " << start.y << ") to (" << goal.x << ", "
                                            << goal.y << ")";
  }
}

TEST(Navfn, UnreachableGoalFails) {
  // A closed box in the middle of the room.
  std::vector<std::string> rows(40, std::string(60, '.'));
  for (int i = 20; i <= 40; ++i) rows[10][i] = rows[30][i] = '#';
  for (int j = 10; j <= 30; ++j) rows[j][20] = rows[j][40] = '#';
  auto costmap = costmapOf(mapFromText(rows));
  NavfnPlanner planner{NavfnConfig{}};
  const PlanResult plan = planner.makePlan(costmap->costmap(), {0.2, 0.2, 0}, {1.5, 1.0, 0});
  EXPECT_FALSE(plan.ok());
  EXPECT_EQ(PlanResult::Status::kNoPath, plan.status);
  EXPECT_TRUE(plan.path.empty());
}

TEST(Navfn, GoalInObstacleAndOffMapFail) {
  auto costmap = costmapOf(wallRoom());
  NavfnPlanner planner{NavfnConfig{}};
  const PlanResult in_wall = planner.makePlan(costmap->costmap(), {0.3, 0.3, 0}, {1.475, 0.5, 0});
  EXPECT_EQ(PlanResult::Status::kGoalInObstacle, in_wall.status);
  EXPECT_NE(std::string::npos, in_wall.message.find("obstacle"));
  const PlanResult off_map = planner.makePlan(costmap->costmap(), {0.3, 0.3, 0}, {5.0, 0.5, 0});
  EXPECT_EQ(PlanResult::Status::kGoalOutsideMap, off_map.status);
  // With a tolerance the closest reachable point is used instead.
  const PlanResult tolerant = planner.makePlan(costmap->costmap(), {0.3, 0.3, 0}, {1.475, 0.5, 0}, 0.3);
  ASSERT_TRUE(tolerant.ok()) << tolerant.message;
  EXPECT_LE(std::hypot(tolerant.path.back().x - 1.475, tolerant.path.back().y - 0.5), 0.3 + 1e-9);
  expectPathSafe(costmap->costmap(), tolerant);
}

namespace {

// Which side of the column centred at (1.525, 1.025) a path passes: +1 above, -1 below.
int sideOfColumn(const PlanResult& plan) {
  for (const Pose2D& p : plan.path) {
    if (std::fabs(p.x - 1.525) < 0.05) return p.y > 1.025 ? 1 : -1;
  }
  return 0;
}

}  // namespace

TEST(Navfn, PathVariabilityIsOffByDefaultAndSeeded) {
  // A square column in the middle of a room, start and goal on its axis: both sides cost the same.
  const auto m = roomMap(61, 41, {{26, 16, 35, 25}});
  auto costmap = costmapOf(m);
  const Pose2D start{0.325, 1.025, 0}, goal{2.725, 1.025, 0};
  NavfnPlanner plain{NavfnConfig{}};
  plain.drawVariation();
  const PlanResult a = plain.makePlan(costmap->costmap(), start, goal);
  plain.drawVariation();
  const PlanResult b = plain.makePlan(costmap->costmap(), start, goal);
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a.path.size(), b.path.size());
  for (size_t i = 0; i < a.path.size(); ++i) EXPECT_DOUBLE_EQ(a.path[i].y, b.path[i].y);

  NavfnConfig varied;
  varied.path_variability = 1.0;
  varied.path_variability_seed = 7;
  NavfnPlanner first{varied}, second{varied};
  std::set<int> sides;
  for (int draw = 0; draw < 12; ++draw) {
    first.drawVariation();
    second.drawVariation();
    const PlanResult p1 = first.makePlan(costmap->costmap(), start, goal);
    const PlanResult p2 = second.makePlan(costmap->costmap(), start, goal);
    ASSERT_TRUE(p1.ok() && p2.ok());
    expectPathSafe(costmap->costmap(), p1);
    ASSERT_EQ(p1.path.size(), p2.path.size()) << "same seed, same draw: same path";
    for (size_t i = 0; i < p1.path.size(); ++i) ASSERT_DOUBLE_EQ(p1.path[i].x, p2.path[i].x);
    sides.insert(sideOfColumn(p1));
  }
  EXPECT_EQ(2u, sides.size()) << "twelve draws should pass the column on both sides";
}

namespace {

// makePlans against makePlan for every goal, to the bit: the same status, message and points.
void expectSameAsOneByOne(const CostGrid& costs, const Pose2D& start, const std::vector<Pose2D>& goals,
                          double tolerance) {
  NavfnPlanner together{NavfnConfig{}}, one_by_one{NavfnConfig{}};
  const std::vector<PlanResult> plans = together.makePlans(costs, start, goals, tolerance);
  ASSERT_EQ(goals.size(), plans.size());
  for (size_t i = 0; i < goals.size(); ++i) {
    const PlanResult single = one_by_one.makePlan(costs, start, goals[i], tolerance);
    ASSERT_EQ(single.status, plans[i].status) << "goal " << i << ": " << single.message << " / " << plans[i].message;
    ASSERT_EQ(single.message, plans[i].message);
    ASSERT_EQ(single.path.size(), plans[i].path.size()) << "goal " << i;
    for (size_t k = 0; k < single.path.size(); ++k) {
      ASSERT_EQ(single.path[k].x, plans[i].path[k].x) << "goal " << i << ", point " << k;
      ASSERT_EQ(single.path[k].y, plans[i].path[k].y) << "goal " << i << ", point " << k;
      ASSERT_EQ(single.path[k].yaw, plans[i].path[k].yaw) << "goal " << i << ", point " << k;
    }
  }
}

}  // namespace

TEST(Navfn, PlansToManyGoalsFromOneWaveAreThePlansOneByOne) {
  // The lab map: goals on free cells all over it, one in a wall, one off the map.
  const marl_mrta::map::OccupancyMap lab = marl_mrta::map::loadMap(std::string(MARL_MRTA_SOURCE_DIR) + "/maps/lab.yaml");
  auto costmap = costmapOf(lab);
  const CostGrid& costs = costmap->costmap();
  std::vector<Pose2D> free_poses;
  for (unsigned y = 3; y < costs.sizeY(); y += 7) {
    for (unsigned x = 5; x < costs.sizeX(); x += 9) {
      double wx, wy;
      costs.mapToWorld(x, y, wx, wy);
      if (costs.cost(x, y) < 253) free_poses.push_back({wx + 0.011, wy - 0.017, 0.1 * x});
    }
  }
  ASSERT_GT(free_poses.size(), 40u);
  std::vector<Pose2D> goals = free_poses;
  goals.push_back({0.0, 0.0, 0.0});
  for (unsigned x = 0; x < costs.sizeX(); ++x) {
    if (costs.cost(x, costs.sizeY() / 2) == 254) {
      double wx, wy;
      costs.mapToWorld(x, costs.sizeY() / 2, wx, wy);
      goals.push_back({wx, wy, 0.0});
      break;
    }
  }
  goals.push_back({-5.0, 2.0, 0.0});
  for (size_t s = 0; s < free_poses.size(); s += 5) expectSameAsOneByOne(costs, free_poses[s], goals, 0.0);
  // With a tolerance the wave covers the whole map.
  expectSameAsOneByOne(costs, free_poses[3], goals, 0.2);

  // A walled-in box: the goals inside are unreachable from outside and the other way round.
  const auto boxed = roomMap(60, 40, {{30, 10, 50, 12}, {30, 28, 50, 30}, {30, 10, 32, 30}, {48, 10, 50, 30}});
  auto boxed_costmap = costmapOf(boxed, 0.3);
  const std::vector<Pose2D> boxed_goals = {{0.5, 0.5, 0.0}, {2.0, 1.0, 0.0}, {0.5, 1.5, 0.0}, {2.8, 1.8, 0.0}};
  expectSameAsOneByOne(boxed_costmap->costmap(), {0.5, 1.0, 0.0}, boxed_goals, 0.0);
  expectSameAsOneByOne(boxed_costmap->costmap(), {2.0, 1.0, 0.0}, boxed_goals, 0.0);
}
