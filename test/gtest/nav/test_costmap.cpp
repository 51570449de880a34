// Costmap core: grid geometry, footprint radii, static/obstacle/inflation layers.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "marl_mrta/nav/costmap_config.h"
#include "marl_mrta/nav/inflation_layer.h"
#include "marl_mrta/nav/layered_costmap.h"
#include "marl_mrta/nav/obstacle_layer.h"
#include "marl_mrta/nav/static_layer.h"
#include "nav_test_helpers.h"

using namespace marl_mrta::nav;
using namespace marl_mrta::nav::testing;

TEST(CostGrid, WorldToMapBoundaries) {
  const CostGrid grid(10, 10, 0.25, 0.0, 0.0);
  unsigned mx = 99, my = 99;
  ASSERT_TRUE(grid.worldToMap(0.0, 0.0, mx, my));
  EXPECT_EQ(0u, mx);
  EXPECT_EQ(0u, my);
  ASSERT_TRUE(grid.worldToMap(0.25, 0.9999, mx, my));
  EXPECT_EQ(1u, mx);
  EXPECT_EQ(3u, my);
  ASSERT_TRUE(grid.worldToMap(2.4999, 2.4999, mx, my));
  EXPECT_EQ(9u, mx);
  EXPECT_EQ(9u, my);
  EXPECT_FALSE(grid.worldToMap(2.5, 1.0, mx, my));
  EXPECT_FALSE(grid.worldToMap(1.0, 2.5, mx, my));
  EXPECT_FALSE(grid.worldToMap(-0.0001, 1.0, mx, my));
  EXPECT_FALSE(grid.worldToMap(std::nan(""), 1.0, mx, my));
  double wx, wy;
  grid.mapToWorld(0, 9, wx, wy);
  EXPECT_DOUBLE_EQ(0.125, wx);
  EXPECT_DOUBLE_EQ(2.375, wy);
  const CellIndex clamped = grid.worldToMapEnforceBounds(-3.0, 7.0);
  EXPECT_EQ(0, clamped.x);
  EXPECT_EQ(9, clamped.y);
  const CellIndex unbounded = grid.worldToMapNoBounds(-0.1, 2.6);
  EXPECT_EQ(-1, unbounded.x);
  EXPECT_EQ(10, unbounded.y);
}

TEST(CostGrid, WorldToMapWithOffsetOrigin) {
  const CostGrid grid(160, 120, 0.05, -0.5, -0.5);  // the lab map's geometry
  unsigned mx, my;
  ASSERT_TRUE(grid.worldToMap(-0.5, -0.5, mx, my));
  EXPECT_EQ(0u, mx);
  ASSERT_TRUE(grid.worldToMap(7.4999, 5.4999, mx, my));
  EXPECT_EQ(159u, mx);
  EXPECT_EQ(119u, my);
  EXPECT_FALSE(grid.worldToMap(7.5, 0.0, mx, my));
  ASSERT_TRUE(grid.worldToMap(1.75, 1.5, mx, my));
  EXPECT_EQ(45u, mx);
  EXPECT_EQ(40u, my);
}

TEST(CostGrid, RaytraceVisitsBothEndsAndRespectsMaxLength) {
  const CostGrid grid(10, 10, 1.0, 0.0, 0.0);
  std::vector<unsigned> cells;
  grid.raytraceLine([&](unsigned i) { cells.push_back(i); }, 0, 0, 5, 2);
  ASSERT_EQ(6u, cells.size());
  EXPECT_EQ(grid.index(0, 0), cells.front());
  EXPECT_EQ(grid.index(5, 2), cells.back());
  cells.clear();
  grid.raytraceLine([&](unsigned i) { cells.push_back(i); }, 0, 0, 8, 0, 3);
  EXPECT_EQ(4u, cells.size());  // 3 steps + the cell reached
}

TEST(CostGrid, UpdateOriginKeepsOverlap) {
  CostGrid grid(10, 10, 1.0, 0.0, 0.0);
  grid.setCost(5, 5, 200);
  grid.setCost(0, 0, 100);
  grid.updateOrigin(2.0, 3.0);
  EXPECT_DOUBLE_EQ(2.0, grid.originX());
  EXPECT_EQ(200, grid.cost(3, 2));  // same world cell
  unsigned count = 0;
  for (uint8_t c : grid.cells()) count += c != 0;
  EXPECT_EQ(1u, count);  // the cell at (0, 0) left the window
}

TEST(CostGrid, RollingWindowSitsWhereCostmap2dPutsIt) {
  // costmap_2d: new origin = robot - getSizeInMetersX() / 2 with getSizeInMetersX() =
  // (size - 1 + 0.5) * resolution, moved by whole cells truncated towards zero. A window one
  // cell off changes DWA's distance grids and local goal (turtlebot3_world, leg 2).
  CostGrid grid(60, 60, 0.05, 0.0, 0.0);
  double stock_x = 0.0, stock_y = 0.0;
  auto stock_move = [](double& origin, double robot) {
    const int cells = static_cast<int>((robot - (60 - 1 + 0.5) * 0.05 / 2 - origin) / 0.05);
    origin += cells * 0.05;
  };
  const double robots[][2] = {{0.0, 0.0}, {-0.0161, 0.0}, {-0.0367, 0.0006}, {-0.0778, 0.0028},
                              {0.52, -0.31}, {1.013, 2.7}, {-3.4, -0.025}, {-3.41, 0.0}};
  for (const auto& robot : robots) {
    grid.centreWindowOn(robot[0], robot[1]);
    stock_move(stock_x, robot[0]);
    stock_move(stock_y, robot[1]);
    EXPECT_NEAR(stock_x, grid.originX(), 1e-9) << "robot x " << robot[0];
    EXPECT_NEAR(stock_y, grid.originY(), 1e-9) << "robot y " << robot[1];
  }
  grid.resize(60, 60, 0.05, 0.0, 0.0);
  grid.centreWindowOn(0.0, 0.0);
  EXPECT_NEAR(-1.45, grid.originX(), 1e-9) << "at rest on the origin: 29 cells back, not 30";
  grid.centreWindowOn(-0.0161, 0.0);
  EXPECT_NEAR(-1.5, grid.originX(), 1e-9);
}

TEST(Footprint, BurgerRadii) {
  const Polygon burger = burgerFootprint();
  EXPECT_NEAR(0.041, inscribedRadius(burger), 1e-9);
  EXPECT_NEAR(std::hypot(0.105, 0.105), circumscribedRadius(burger), 1e-9);
  const Polygon padded = padFootprint(burger, 0.01);
  EXPECT_NEAR(0.051, inscribedRadius(padded), 1e-9);
  EXPECT_NEAR(std::hypot(0.115, 0.115), circumscribedRadius(padded), 1e-9);
}

TEST(Footprint, ParsesStringAndRejectsBadInput) {
  const Polygon p = parseFootprintString("[[-0.105, -0.105], [-0.105, 0.105], [0.041, 0.105], [0.041, -0.105]]");
  ASSERT_EQ(4u, p.size());
  EXPECT_DOUBLE_EQ(0.041, p[2].x);
  EXPECT_THROW(parseFootprintString("[[0, 0], [1, 1]]"), std::invalid_argument);
  EXPECT_THROW(parseFootprintString("[[0, 0], [1, 1], [1]]"), std::invalid_argument);
  EXPECT_THROW(parseFootprintString("0.1"), std::invalid_argument);
  EXPECT_THROW(parseFootprintString("[[0, 0], [1, 1], [1, 0]] extra"), std::invalid_argument);
}

namespace {

// A costmap with a static layer + inflation over a map.
std::unique_ptr<LayeredCostmap> staticInflatedCostmap(const marl_mrta::map::OccupancyMap& m, double inflation_radius,
                                                      double scaling, const Polygon& footprint) {
  auto costmap = std::make_unique<LayeredCostmap>(false, false);
  costmap->resizeMap(m.width, m.height, m.resolution, m.origin_x, m.origin_y);
  costmap->setFootprint(footprint);
  auto static_layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, *costmap);
  static_layer->setMap(m);
  costmap->addLayer(std::move(static_layer));
  costmap->addLayer(std::make_unique<InflationLayer>("inflation_layer", InflationLayerConfig{inflation_radius, scaling, false}));
  costmap->updateMap(Pose2D{});
  return costmap;
}

// The inflation formula on an exact Euclidean distance (in cells).
uint8_t expectedInflation(double d_cells, double resolution, double inscribed, double radius, double k) {
  if (d_cells == 0.0) return 254;
  const double d = d_cells * resolution;
  if (d <= inscribed) return 253;
  if (d_cells > std::ceil(radius / resolution)) return 0;
  return static_cast<uint8_t>(252.0 * std::exp(-k * (d - inscribed)));
}

void expectInflationMatchesFormula(const marl_mrta::map::OccupancyMap& m, double radius, double k) {
  const Polygon footprint = padFootprint(burgerFootprint(), 0.01);
  auto costmap = staticInflatedCostmap(m, radius, k, footprint);
  const CostGrid& grid = costmap->costmap();
  std::vector<std::pair<int, int>> obstacles;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x)
      if (m.data[y * m.width + x] == 100) obstacles.push_back({x, y});
  int mismatches = 0;
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      double nearest = 1e9;
      for (const auto& o : obstacles) nearest = std::min(nearest, std::hypot(x - o.first, y - o.second));
      const uint8_t expected = expectedInflation(nearest, m.resolution, inscribedRadius(footprint), radius, k);
      if (grid.cost(x, y) != expected && ++mismatches < 5) {
        ADD_FAILURE() << "cell (" << x << ", " << y << ") distance " << nearest << ": cost " << int(grid.cost(x, y))
                      << ", formula " << int(expected);
      }
    }
  }
  EXPECT_EQ(0, mismatches);
}

}  // namespace

TEST(InflationLayer, SingleObstacleMatchesFormulaCellByCell) {
  std::vector<std::string> rows(41, std::string(41, '.'));
  rows[20][20] = '#';
  expectInflationMatchesFormula(mapFromText(rows), 0.5, 3.0);
}

TEST(InflationLayer, WallAndPillarsMatchFormulaCellByCell) {
  std::vector<std::string> rows(50, std::string(60, '.'));
  for (int x = 0; x < 60; ++x) rows[45][x] = '#';  // a wall
  rows[10][12] = '#';
  rows[30][40] = '#';
  expectInflationMatchesFormula(mapFromText(rows), 1.0, 3.0);  // TurtleBot3's values
}

TEST(InflationLayer, BurgerInscribedCellsAreTheFourNeighbours) {
  // Padded Burger: inscribed radius 0.051 m > one 0.05 m cell, < a diagonal (0.0707 m).
  std::vector<std::string> rows(9, std::string(9, '.'));
  rows[4][4] = '#';
  auto costmap = staticInflatedCostmap(mapFromText(rows), 1.0, 3.0, padFootprint(burgerFootprint(), 0.01));
  const CostGrid& g = costmap->costmap();
  EXPECT_EQ(254, g.cost(4, 4));
  EXPECT_EQ(253, g.cost(5, 4));
  EXPECT_EQ(253, g.cost(4, 3));
  EXPECT_LT(g.cost(5, 5), 253);
  EXPECT_EQ(static_cast<uint8_t>(252 * std::exp(-3.0 * (0.05 * std::sqrt(2.0) - 0.051))), g.cost(5, 5));
}

TEST(StaticLayer, TrinaryInterpretationAndResize) {
  const auto m = mapFromText({"#.?", "..."});
  LayeredCostmap costmap(false, false);
  costmap.setFootprint(burgerFootprint());
  auto layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, costmap);
  StaticLayer* raw = layer.get();
  raw->setMap(m);
  costmap.addLayer(std::move(layer));
  costmap.updateMap(Pose2D{});
  ASSERT_EQ(3u, costmap.costmap().sizeX());
  ASSERT_EQ(2u, costmap.costmap().sizeY());
  EXPECT_EQ(254, costmap.costmap().cost(0, 1));
  EXPECT_EQ(0, costmap.costmap().cost(1, 1));
  EXPECT_EQ(255, costmap.costmap().cost(2, 1));  // unknown kept (track_unknown_space default true)
  StaticLayerConfig untracked;
  untracked.track_unknown_space = false;
  LayeredCostmap other(false, false);
  StaticLayer second("s", untracked, other);
  EXPECT_EQ(0, second.interpretValue(-1));
  EXPECT_EQ(254, second.interpretValue(100));
  EXPECT_EQ(0, second.interpretValue(99));
}

namespace {

ObservationSourceConfig scanSource() {
  ObservationSourceConfig source;
  source.name = "scan";
  source.marking = true;
  source.clearing = true;
  source.obstacle_range = 3.0;
  source.raytrace_range = 3.5;
  return source;
}

LaserScanData scanOf(const std::vector<float>& ranges) {
  LaserScanData scan;
  scan.angle_min = 0.0;
  scan.angle_increment = 2.0 * M_PI / ranges.size();
  scan.range_min = 0.12;
  scan.range_max = 3.5;
  scan.ranges = ranges;
  return scan;
}

}  // namespace

TEST(ObstacleLayer, MarksWithinObstacleRangeAndClearsAlongRays) {
  LayeredCostmap costmap(false, false);
  costmap.resizeMap(200, 200, 0.05, -5.0, -5.0);
  costmap.setFootprint(padFootprint(burgerFootprint(), 0.01));
  ObstacleLayerConfig config;
  config.sources.push_back(scanSource());
  auto layer = std::make_unique<ObstacleLayer>("obstacle_layer", config);
  ObstacleLayer* obstacles = layer.get();
  costmap.addLayer(std::move(layer));
  const SensorPose sensor{0.0, 0.0, 0.18, 0.0};
  // Beam 0 (+x) hits at 2 m, beam 1 (+y) at 3.2 m (beyond obstacle_range), beam 2 reads 0 (invalid).
  obstacles->addObservation(0, laserScanToObservation(scanOf({2.0f, 3.2f, 0.0f, 1.0f}), sensor, config.sources[0]));
  costmap.updateMap(Pose2D{});
  unsigned mx, my;
  costmap.costmap().worldToMap(2.0, 0.0, mx, my);
  EXPECT_EQ(254, costmap.costmap().cost(mx, my));
  costmap.costmap().worldToMap(0.0, 3.2, mx, my);
  EXPECT_EQ(0, costmap.costmap().cost(mx, my)) << "beyond obstacle_range must not be marked";
  costmap.costmap().worldToMap(0.0, -1.0, mx, my);
  EXPECT_EQ(254, costmap.costmap().cost(mx, my));
  // The obstacle at 2 m moves away: the next scan sees 3.0 m and clears the old cell.
  obstacles->addObservation(0, laserScanToObservation(scanOf({3.0f, 3.2f, 0.0f, 1.0f}), sensor, config.sources[0]));
  costmap.updateMap(Pose2D{});
  costmap.costmap().worldToMap(2.0, 0.0, mx, my);
  EXPECT_EQ(0, costmap.costmap().cost(mx, my));
}

TEST(ObstacleLayer, InfIsValidClearsOnlyWhenEnabled) {
  ObservationSourceConfig source = scanSource();
  const std::vector<float> ranges{std::numeric_limits<float>::infinity(), 1.0f};
  EXPECT_EQ(1u, laserScanToObservation(scanOf(ranges), SensorPose{}, source).points.size());
  source.inf_is_valid = true;
  const Observation o = laserScanToObservation(scanOf(ranges), SensorPose{}, source);
  ASSERT_EQ(2u, o.points.size());
  EXPECT_NEAR(3.5, o.points[0].x, 1e-3);  // at range_max: clears, but beyond obstacle_range so never marks
}

TEST(ObstacleLayer, RollingWindowKeepsObstaclesInPlace) {
  LayeredCostmap costmap(true, false);
  costmap.resizeMap(60, 60, 0.05, 0.0, 0.0);
  costmap.setFootprint(padFootprint(burgerFootprint(), 0.01));
  ObstacleLayerConfig config;
  config.sources.push_back(scanSource());
  auto layer = std::make_unique<ObstacleLayer>("obstacle_layer", config);
  ObstacleLayer* obstacles = layer.get();
  costmap.addLayer(std::move(layer));
  obstacles->addObservation(0, laserScanToObservation(scanOf({1.0f, 3.4f, 3.4f, 3.4f}), SensorPose{}, config.sources[0]));
  costmap.updateMap(Pose2D{0.0, 0.0, 0.0});
  EXPECT_NEAR(-1.45, costmap.costmap().originX(), 1e-9);  // as costmap_2d (CostGrid.RollingWindow...)
  costmap.updateMap(Pose2D{0.5, 0.2, 0.0});
  EXPECT_NEAR(-1.0, costmap.costmap().originX(), 1e-9);
  unsigned mx, my;
  ASSERT_TRUE(costmap.costmap().worldToMap(1.0, 0.0, mx, my));
  EXPECT_EQ(254, costmap.costmap().cost(mx, my));
}

TEST(ObstacleLayer, ClearAreaForgetsObstaclesAwayFromTheRobot) {
  LayeredCostmap costmap(false, false);
  costmap.resizeMap(100, 100, 0.05, -2.5, -2.5);
  costmap.setFootprint(padFootprint(burgerFootprint(), 0.01));
  ObstacleLayerConfig config;
  config.sources.push_back(scanSource());
  auto layer = std::make_unique<ObstacleLayer>("obstacle_layer", config);
  ObstacleLayer* obstacles = layer.get();
  costmap.addLayer(std::move(layer));
  obstacles->addObservation(0, laserScanToObservation(scanOf({0.5f, 2.0f}), SensorPose{}, config.sources[0]));
  costmap.updateMap(Pose2D{});
  obstacles->clearArea(0.0, 0.0, 3.0, false);  // conservative reset: beyond 1.5 m goes
  costmap.updateMap(Pose2D{});
  unsigned mx, my;
  costmap.costmap().worldToMap(0.5, 0.0, mx, my);
  EXPECT_EQ(254, costmap.costmap().cost(mx, my));
  costmap.costmap().worldToMap(-2.0, 0.0, mx, my);
  EXPECT_EQ(0, costmap.costmap().cost(mx, my));
}

TEST(LayeredCostmap, IncrementalUpdatesEqualAFullRecomputation) {
  // Static + obstacle + inflation over a room; scans from a moving robot that sees a moving box.
  const auto m = roomMap(120, 80, {{50, 30, 56, 36}});
  LayeredCostmap costmap(false, false);
  costmap.setFootprint(padFootprint(burgerFootprint(), 0.01));
  auto static_layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, costmap);
  static_layer->setMap(m);
  costmap.addLayer(std::move(static_layer));
  ObstacleLayerConfig config;
  config.sources.push_back(scanSource());
  auto obstacle_layer = std::make_unique<ObstacleLayer>("obstacle_layer", config);
  ObstacleLayer* obstacles = obstacle_layer.get();
  costmap.addLayer(std::move(obstacle_layer));
  auto inflation_layer = std::make_unique<InflationLayer>("inflation_layer", InflationLayerConfig{1.0, 3.0, false});
  InflationLayer* inflation = inflation_layer.get();
  costmap.addLayer(std::move(inflation_layer));
  for (int step = 0; step < 12; ++step) {
    const Pose2D robot{1.0 + 0.2 * step, 1.0 + 0.05 * step, 0.1 * step};
    std::vector<float> ranges(90);
    for (size_t i = 0; i < ranges.size(); ++i) ranges[i] = static_cast<float>(0.6 + 0.03 * ((i * 7 + step * 5) % 40));
    obstacles->addObservation(0, laserScanToObservation(scanOf(ranges), {robot.x, robot.y, 0.18, robot.yaw},
                                                        config.sources[0]));
    costmap.updateMap(robot);
    const std::vector<uint8_t> incremental = costmap.costmap().cells();
    inflation->reset();  // next update recomputes every cell
    costmap.updateMap(robot);
    ASSERT_EQ(incremental, costmap.costmap().cells()) << "after step " << step;
  }
}

namespace {
// Test double: marks a set of cells lethal and asks for the area around the cells it changed.
class MarkedCellsLayer : public Layer {
 public:
  MarkedCellsLayer() : Layer("marked_cells") {}
  void mark(std::set<std::pair<unsigned, unsigned>> cells) {
    changed_.insert(marked_.begin(), marked_.end());
    changed_.insert(cells.begin(), cells.end());
    marked_ = std::move(cells);
  }
  void updateBounds(const Pose2D&, Bounds& bounds) override {
    for (const auto& cell : changed_) {
      bounds.touch(origin_x_ + cell.first * resolution_, origin_y_ + cell.second * resolution_);
      bounds.touch(origin_x_ + (cell.first + 0.999) * resolution_, origin_y_ + (cell.second + 0.999) * resolution_);
    }
    changed_.clear();
  }
  void updateCosts(CostGrid& master, const CellWindow& window) override {
    for (const auto& cell : marked_) {
      const int x = static_cast<int>(cell.first), y = static_cast<int>(cell.second);
      if (x >= window.min_x && x < window.max_x && y >= window.min_y && y < window.max_y) {
        master.setCost(cell.first, cell.second, kLethalObstacle);
      }
    }
  }
  void matchSize(const LayeredCostmap& master) override {
    resolution_ = master.costmap().resolution();
    origin_x_ = master.costmap().originX();
    origin_y_ = master.costmap().originY();
  }

 private:
  std::set<std::pair<unsigned, unsigned>> marked_, changed_;
  double resolution_ = 0.05, origin_x_ = 0.0, origin_y_ = 0.0;
};
}  // namespace

TEST(LayeredCostmap, IncrementalUpdatesEqualAFullRecomputationForScatteredChanges) {
  // Changes in several far-apart places of one update are re-inflated as separate boxes; wall
  // hits next to a wall, lone cells, clusters and cells that come and go all give the field a
  // full recomputation gives.
  const auto m = roomMap(200, 140, {{50, 30, 56, 36}, {120, 80, 140, 84}, {160, 20, 162, 110}});
  LayeredCostmap costmap(false, false);
  costmap.setFootprint(padFootprint(burgerFootprint(), 0.01));
  auto static_layer = std::make_unique<StaticLayer>("static_layer", StaticLayerConfig{}, costmap);
  static_layer->setMap(m);
  costmap.addLayer(std::move(static_layer));
  auto marked_layer = std::make_unique<MarkedCellsLayer>();
  MarkedCellsLayer* marked = marked_layer.get();
  costmap.addLayer(std::move(marked_layer));
  auto inflation_layer = std::make_unique<InflationLayer>("inflation_layer", InflationLayerConfig{1.0, 3.0, false});
  InflationLayer* inflation = inflation_layer.get();
  costmap.addLayer(std::move(inflation_layer));
  costmap.updateMap(Pose2D{});
  std::mt19937 random(7);
  std::uniform_int_distribution<unsigned> x_of(1, 198), y_of(1, 138), count_of(0, 12);
  for (int step = 0; step < 40; ++step) {
    std::set<std::pair<unsigned, unsigned>> cells;
    for (unsigned k = count_of(random); k > 0; --k) cells.insert({x_of(random), y_of(random)});
    for (unsigned y = 10; y < 130; y += 7) {
      if ((y + step) % 3 == 0) cells.insert({1, y});  // beside the left wall, on and off
    }
    if (step % 2 == 0) cells.insert({80 + step, 60});  // a moving block
    if (step % 2 == 0) cells.insert({81 + step, 60});
    marked->mark(cells);
    costmap.updateMap(Pose2D{});
    const std::vector<uint8_t> incremental = costmap.costmap().cells();
    inflation->reset();
    costmap.updateMap(Pose2D{});
    ASSERT_EQ(incremental, costmap.costmap().cells()) << "after step " << step;
  }
}
