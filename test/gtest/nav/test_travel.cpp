// The travel binding (libmarl_mrta_travel, C ABI): the paths between every pair of poses are
// navfn's on move_base's global costmap, to the bit; failures name the pose.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "marl_mrta/nav/move_base_core.h"
#include "marl_mrta/nav/static_layer.h"
#include "marl_mrta/nav/travel_c_api.h"

using namespace marl_mrta::nav;

namespace {

const std::string kSourceDir = MARL_MRTA_SOURCE_DIR;
const std::string kLab = kSourceDir + "/maps/lab.yaml";
const std::string kNavConfig = kSourceDir + "/config/nav";

// The start poses and tasks of scenarios/lab_2r.xml.
const std::vector<double> kLab2r = {0.5, 0.5, 0.0,  0.5, 4.5, 0.0,  1.2, 1.0, 0.0,  2.8, 1.9, 1.570796,
                                    1.2, 4.0, 0.0,  2.8, 3.1, -1.570796,  4.4, 0.8, 0.0,  6.2, 1.9, 1.570796,
                                    4.4, 4.2, 0.0,  6.2, 3.1, -1.570796};

struct Planned {
  MarlMrtaTravel* travel = nullptr;
  std::string error;
  int failed_node = -2;
};

Planned plan(const std::string& map_yaml, const std::string& config_dir, const std::vector<double>& poses) {
  Planned result;
  char error[512];
  result.travel = marl_mrta_travel_plan(map_yaml.c_str(), config_dir.c_str(), static_cast<int>(poses.size() / 3),
                                        poses.data(), error, sizeof error, &result.failed_node);
  result.error = error;
  return result;
}

std::vector<double> pathOf(const MarlMrtaTravel* travel, int a, int b) {
  std::vector<double> xy(2 * marl_mrta_travel_path_size(travel, a, b));
  marl_mrta_travel_path(travel, a, b, xy.data());
  return xy;
}

double lengthOf(const std::vector<double>& xy) {
  double length = 0.0;
  for (size_t i = 2; i + 1 < xy.size(); i += 2) length += std::hypot(xy[i] - xy[i - 2], xy[i + 1] - xy[i - 1]);
  return length;
}

// move_base as its node builds it: the seven parameter files, the map as map_server publishes
// it (resolution as float32); the global costmap updated once.
std::unique_ptr<MoveBaseCore> moveBaseOnLab() {
  auto core = std::make_unique<MoveBaseCore>(readMoveBaseConfig(ParamNode(loadMoveBaseParams(kNavConfig), "move_base")));
  marl_mrta::map::OccupancyMap occupancy = marl_mrta::map::loadMap(kLab);
  occupancy.resolution = static_cast<float>(occupancy.resolution);
  core->globalCostmap().layersOfType<StaticLayer>().front()->setMap(occupancy);
  core->globalCostmap().updateMap(Pose2D{});
  return core;
}

// A map_server map written to a temporary directory: `rows` top first, '#' occupied, '.' free,
// '?' unknown; the map's lower-left corner at `origin`.
class TemporaryMap {
 public:
  explicit TemporaryMap(const std::vector<std::string>& rows, const std::string& origin = "[0.0, 0.0, 0.0]") {
    char pattern[] = "/tmp/marl_mrta_travel_XXXXXX";
    dir_ = mkdtemp(pattern);
    std::ofstream pgm(dir_ + "/map.pgm", std::ios::binary);
    pgm << "P5\n" << rows.front().size() << " " << rows.size() << "\n255\n";
    for (const std::string& row : rows) {
      for (char c : row) pgm.put(static_cast<char>(c == '#' ? 0 : c == '?' ? 205 : 254));
    }
    std::ofstream yaml(dir_ + "/map.yaml");
    yaml << "image: map.pgm\nresolution: 0.05\norigin: " << origin << "\nnegate: 0\n"
         << "occupied_thresh: 0.65\nfree_thresh: 0.196\n";
  }
  ~TemporaryMap() {
    std::remove((dir_ + "/map.pgm").c_str());
    std::remove((dir_ + "/map.yaml").c_str());
    rmdir(dir_.c_str());
  }
  std::string yaml() const { return dir_ + "/map.yaml"; }

 private:
  std::string dir_;
};

// A 4 m x 3 m room with a walled-in box around (3.0, 1.5).
std::vector<std::string> roomWithSealedBox() {
  std::vector<std::string> rows(60, std::string(80, '.'));
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) {
      const bool border = x == 0 || y == 0 || x == 79 || y == 59;
      const bool box = x >= 50 && x < 70 && y >= 20 && y < 40 && (x < 52 || x >= 68 || y < 22 || y >= 38);
      if (border || box) rows[59 - y][x] = '#';
    }
  }
  return rows;
}

}  // namespace

TEST(Travel, PathsAreNavfnsOnMoveBasesGlobalCostmap) {
  const Planned planned = plan(kLab, kNavConfig, kLab2r);
  ASSERT_NE(nullptr, planned.travel) << planned.error;
  EXPECT_EQ(-1, planned.failed_node);
  EXPECT_EQ("", planned.error);

  // move_base's own plan for each pair, with the default tolerance.
  const std::unique_ptr<MoveBaseCore> move_base = moveBaseOnLab();
  MoveBaseCore& core = *move_base;
  const int n = static_cast<int>(kLab2r.size() / 3);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      if (a == b) {
        EXPECT_EQ(0, marl_mrta_travel_path_size(planned.travel, a, b));
        continue;
      }
      const Pose2D start{kLab2r[3 * a], kLab2r[3 * a + 1], kLab2r[3 * a + 2]};
      const Pose2D goal{kLab2r[3 * b], kLab2r[3 * b + 1], kLab2r[3 * b + 2]};
      const PlanResult expected = core.planner().makePlan(core.globalCostmap().costmap(), start, goal);
      ASSERT_TRUE(expected.ok()) << expected.message;
      const std::vector<double> xy = pathOf(planned.travel, a, b);
      ASSERT_EQ(2 * expected.path.size(), xy.size()) << a << " -> " << b;
      for (size_t k = 0; k < expected.path.size(); ++k) {
        ASSERT_EQ(expected.path[k].x, xy[2 * k]) << a << " -> " << b << ", point " << k;
        ASSERT_EQ(expected.path[k].y, xy[2 * k + 1]) << a << " -> " << b << ", point " << k;
      }
      EXPECT_EQ(goal.x, xy[xy.size() - 2]);
      EXPECT_EQ(goal.y, xy.back());
    }
  }
  marl_mrta_travel_free(planned.travel);
}

TEST(Travel, AFreeStraightLineIsDrivenAlmostStraight) {
  // Tasks B1 and B3 of lab_2r: 3.4 m along x = 4.4 through the east room, the line free of
  // obstacles and inscribed cells.
  const double x = 4.4, y0 = 0.8, y1 = 4.2;
  const std::unique_ptr<MoveBaseCore> move_base = moveBaseOnLab();
  const CostGrid& costs = move_base->globalCostmap().costmap();
  for (double y = y0; y <= y1; y += 0.01) {
    unsigned mx, my;
    ASSERT_TRUE(costs.worldToMap(x, y, mx, my));
    ASSERT_LT(costs.cost(mx, my), kInscribedInflated) << "the line is blocked at y = " << y;
  }
  const Planned planned = plan(kLab, kNavConfig, {x, y0, 0.0, x, y1, 0.0});
  ASSERT_NE(nullptr, planned.travel) << planned.error;
  for (auto [a, b] : {std::make_pair(0, 1), std::make_pair(1, 0)}) {
    const double length = lengthOf(pathOf(planned.travel, a, b));
    EXPECT_GT(length, (y1 - y0) * 0.99);
    // navfn's points sit on cell corners: the path's first point is up to half a cell's
    // diagonal (0.035 m) from the start.
    EXPECT_LT(length, (y1 - y0) * 1.03 + 0.036);
  }
  marl_mrta_travel_free(planned.travel);
}

TEST(Travel, AnUnreachablePoseReportsItsIndex) {
  const TemporaryMap map(roomWithSealedBox());
  // Pose 2 stands inside the sealed box: every plan from and to it fails.
  const Planned walled_in = plan(map.yaml(), kNavConfig, {0.5, 0.5, 0.0, 1.5, 2.5, 0.0, 3.0, 1.5, 0.0, 3.6, 0.4, 0.0});
  EXPECT_EQ(nullptr, walled_in.travel);
  EXPECT_EQ(2, walled_in.failed_node) << walled_in.error;
  EXPECT_EQ(0u, walled_in.error.find("pose 2 (3.00, 1.50): cannot be reached: 6 of the 6 plans from and to it failed (")) << walled_in.error;

  // Pose 1 is in the box's wall: in an obstacle of the global costmap.
  const Planned in_wall = plan(map.yaml(), kNavConfig, {0.5, 0.5, 0.0, 2.525, 1.5, 0.0, 1.5, 2.5, 0.0});
  EXPECT_EQ(nullptr, in_wall.travel);
  EXPECT_EQ(1, in_wall.failed_node);
  EXPECT_EQ("pose 1 (2.52, 1.50): in an obstacle or the inscribed zone of the global costmap (cost 254)", in_wall.error);

  // Pose 0 is off the map.
  const Planned off_map = plan(map.yaml(), kNavConfig, {-1.0, 0.5, 0.0, 1.5, 2.5, 0.0});
  EXPECT_EQ(nullptr, off_map.travel);
  EXPECT_EQ(0, off_map.failed_node);
  EXPECT_EQ("pose 0 (-1.00, 0.50): off the map " + map.yaml(), off_map.error);

  // Pose 1 is on the lab map's outermost column, free but an obstacle to navfn.
  const Planned on_border = plan(kLab, kNavConfig, {0.5, 0.5, 0.0, -0.47, 2.93, 0.0});
  EXPECT_EQ(nullptr, on_border.travel);
  EXPECT_EQ(1, on_border.failed_node);
  EXPECT_EQ("pose 1 (-0.47, 2.93): on the outer cells of the global costmap, which navfn treats as obstacles",
            on_border.error);
}

TEST(Travel, MapAndParameterErrorsReportNoPose) {
  const Planned no_map = plan(kSourceDir + "/test/data/maps/bad_missing_image.yaml", kNavConfig, kLab2r);
  EXPECT_EQ(nullptr, no_map.travel);
  EXPECT_EQ(-1, no_map.failed_node);
  EXPECT_NE(std::string::npos, no_map.error.find("bad_missing_image.yaml: image: ")) << no_map.error;

  const Planned no_config = plan(kLab, kSourceDir + "/test/data/nav", kLab2r);
  EXPECT_EQ(nullptr, no_config.travel);
  EXPECT_EQ(-1, no_config.failed_node);
  EXPECT_NE(std::string::npos, no_config.error.find("costmap_common_params_burger.yaml: cannot be read")) << no_config.error;

  // The message is cut to the buffer, NUL-terminated.
  char error[16];
  int failed_node = 0;
  EXPECT_EQ(nullptr, marl_mrta_travel_plan(kLab.c_str(), "/nonexistent", 0, nullptr, error, sizeof error, &failed_node));
  EXPECT_EQ(15u, std::string(error).size());
  EXPECT_EQ(-1, failed_node);
}

namespace {

// config/nav copied to a temporary directory, with lines added to two of its files.
class NavigationCopy {
 public:
  NavigationCopy(const std::string& costmap_lines, const std::string& navfn_lines) {
    char pattern[] = "/tmp/marl_mrta_nav_XXXXXX";
    dir_ = mkdtemp(pattern);
    for (const auto& entry : std::filesystem::directory_iterator(kNavConfig)) {
      std::filesystem::copy_file(entry.path(), dir_ / entry.path().filename());
    }
    std::ofstream(dir_ / "costmap_common_params_burger.yaml", std::ios::app) << "\n" << costmap_lines;
    std::ofstream(dir_ / "navfn_params.yaml", std::ios::app) << "\n" << navfn_lines;
  }
  ~NavigationCopy() { std::filesystem::remove_all(dir_); }
  std::string dir() const { return dir_.string(); }

 private:
  std::filesystem::path dir_;
};

// A 6 m x 4 m room; across its middle a band of unknown cells 0.15 m wide (narrower than the
// Burger's footprint) from the floor to 2.4 m, free above.
std::vector<std::string> roomWithUnknownBand() {
  std::vector<std::string> rows(80, std::string(120, '.'));
  for (int y = 0; y < 80; ++y) {
    for (int x = 0; x < 120; ++x) {
      if (x == 0 || y == 0 || x == 119 || y == 79) {
        rows[79 - y][x] = '#';
      } else if (y < 48 && x >= 59 && x < 62) {
        rows[79 - y][x] = '?';
      }
    }
  }
  return rows;
}

}  // namespace

// Unknown space is what move_base's global costmap makes of it, with the navigation's files:
// TurtleBot3's (track_unknown_space unset) free, so the travel path crosses the band; with
// track_unknown_space: true and navfn's allow_unknown false an obstacle, so it goes round. Each
// path is move_base's own plan from the robot standing at the start. The map's origin puts the
// world's (0, 0) in the band, where no robot stands: no footprint is cleared into it.
TEST(Travel, UnknownSpaceIsWhatMoveBasesCostmapMakesOfIt) {
  const TemporaryMap map(roomWithUnknownBand(), "[-3.0, -1.6, 0.0]");
  const std::vector<double> poses = {-2.0, 0.0, 0.0, 2.0, 0.0, 0.0};
  const NavigationCopy as_shipped("", "");
  const NavigationCopy tracked("track_unknown_space: true\n", "NavfnROS:\n  allow_unknown: false\n");
  double length_as_shipped = 0.0;
  for (const NavigationCopy* navigation : {&as_shipped, &tracked}) {
    const Planned planned = plan(map.yaml(), navigation->dir(), poses);
    ASSERT_NE(nullptr, planned.travel) << planned.error;
    MoveBaseCore core(readMoveBaseConfig(ParamNode(loadMoveBaseParams(navigation->dir()), "move_base")));
    marl_mrta::map::OccupancyMap occupancy = marl_mrta::map::loadMap(map.yaml());
    occupancy.resolution = static_cast<float>(occupancy.resolution);
    core.globalCostmap().layersOfType<StaticLayer>().front()->setMap(occupancy);
    const Pose2D start{poses[0], poses[1], poses[2]}, goal{poses[3], poses[4], poses[5]};
    core.globalCostmap().updateMap(start);
    const PlanResult expected = core.planner().makePlan(core.globalCostmap().costmap(), start, goal);
    ASSERT_TRUE(expected.ok()) << expected.message;
    const std::vector<double> xy = pathOf(planned.travel, 0, 1);
    ASSERT_EQ(2 * expected.path.size(), xy.size());
    int unknown_points = 0;
    for (size_t k = 0; k < expected.path.size(); ++k) {
      ASSERT_EQ(expected.path[k].x, xy[2 * k]) << "point " << k;
      ASSERT_EQ(expected.path[k].y, xy[2 * k + 1]) << "point " << k;
      int cx, cy;
      if (occupancy.worldToCell(xy[2 * k], xy[2 * k + 1], cx, cy) && occupancy.at(cx, cy) == -1) ++unknown_points;
    }
    if (navigation == &as_shipped) {
      EXPECT_GT(unknown_points, 0) << "TurtleBot3's costmap leaves unknown cells free: the path crosses the band";
      length_as_shipped = lengthOf(xy);
      EXPECT_LT(length_as_shipped, 4.1);
    } else {
      EXPECT_EQ(0, unknown_points) << "tracked unknown space is an obstacle to navfn without allow_unknown";
      EXPECT_GT(lengthOf(xy), length_as_shipped + 0.3);
    }
    marl_mrta_travel_free(planned.travel);
  }
}
