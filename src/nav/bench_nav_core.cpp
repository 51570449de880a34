// Speed of the navigation cores on a map (no ROS): planning time per plan on the global
// costmap, local costmap update with a simulated 360-beam scan, DWA controller cycle, and the
// travel binding's paths between every pair of 10 and 48 poses (libmarl_mrta_travel, as the
// embedded executor calls it, against one plan per pair).
//   bench_nav_core <config_dir> <map.yaml> [<map.yaml> ...]   -> JSON on stdout
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <random>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/move_base_core.h"
#include "marl_mrta/nav/cpu_clock.h"
#include "marl_mrta/nav/static_layer.h"
#include "marl_mrta/nav/travel_c_api.h"

using namespace marl_mrta;
using namespace marl_mrta::nav;

namespace {

using Clock = marl_mrta::nav::ThreadCpuClock;  // CPU time: the machine may be shared
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

struct Stats {
  std::vector<double> samples;
  double mean() const {
    double s = 0;
    for (double v : samples) s += v;
    return samples.empty() ? 0.0 : s / samples.size();
  }
  double percentile(double p) const {
    if (samples.empty()) return 0.0;
    std::vector<double> v = samples;
    std::sort(v.begin(), v.end());
    return v[std::min(v.size() - 1, static_cast<size_t>(p * (v.size() - 1) + 0.5))];
  }
  std::string json() const {
    char buf[160];
    std::snprintf(buf, sizeof buf, "{\"n\": %zu, \"mean_ms\": %.4f, \"median_ms\": %.4f, \"p95_ms\": %.4f}", samples.size(),
                  mean(), percentile(0.5), percentile(0.95));
    return buf;
  }
};

// A 360-beam scan cast on the occupancy grid (the simulator's lidar, without the other robots).
LaserScanData castScan(const map::OccupancyMap& m, const Pose2D& sensor) {
  LaserScanData scan;
  scan.angle_min = 0.0;
  scan.angle_increment = 2.0 * M_PI / 360;
  scan.range_min = 0.12;
  scan.range_max = 3.5;
  for (int i = 0; i < 360; ++i) {
    const double a = sensor.yaw + i * scan.angle_increment;
    float range = 0.0f;  // no return: 0, like the LDS-01 driver
    for (double r = scan.range_min; r < scan.range_max; r += m.resolution / 2) {
      int cx, cy;
      if (!m.worldToCell(sensor.x + r * std::cos(a), sensor.y + r * std::sin(a), cx, cy)) break;
      if (m.at(cx, cy) == map::OccupancyMap::kOccupied) {
        range = static_cast<float>(r);
        break;
      }
    }
    scan.ranges.push_back(range);
  }
  return scan;
}

MoveBaseConfig loadConfig(const std::string& dir) {
  return readMoveBaseConfig(ParamNode(loadMoveBaseParams(dir), "move_base"));
}

// marl_mrta_travel_plan for `count` of `free_poses` reachable from one another (best of a few
// runs, each building the costmap too), and the same paths planned one pair at a time on `core`.
std::string benchTravel(MoveBaseCore& core, const std::string& config_dir, const std::string& map_file,
                        const std::vector<Pose2D>& free_poses, size_t count, std::mt19937& rng) {
  std::uniform_int_distribution<size_t> pick(0, free_poses.size() - 1);
  std::vector<Pose2D> poses;
  for (int tries = 1; poses.size() < count && tries < 100000; ++tries) {
    if (poses.size() == 1 && tries % 100 == 0) poses.clear();  // the first one is walled in: another
    const Pose2D candidate = free_poses[pick(rng)];
    const bool reachable = poses.empty() || (core.makePlan(poses.front(), candidate, 0.0).ok() &&
                                             core.makePlan(candidate, poses.front(), 0.0).ok());
    if (reachable) poses.push_back(candidate);
  }
  std::vector<double> flat;
  for (const Pose2D& p : poses) flat.insert(flat.end(), {p.x, p.y, p.yaw});
  const int n = static_cast<int>(poses.size());
  Stats together, pairwise;
  char error[256] = "";
  for (int run = 0; run < 3; ++run) {
    int failed_node = -1;
    const auto t0 = Clock::now();
    MarlMrtaTravel* travel =
        marl_mrta_travel_plan(map_file.c_str(), config_dir.c_str(), n, flat.data(), error, sizeof error, &failed_node);
    together.samples.push_back(msSince(t0));
    if (!travel) {
      std::cerr << "bench_nav_core: travel: " << error << "\n";
      std::exit(1);
    }
    marl_mrta_travel_free(travel);
  }
  const auto t0 = Clock::now();
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      if (a != b) core.planner().makePlan(core.globalCostmap().costmap(), poses[a], poses[b]);
    }
  }
  pairwise.samples.push_back(msSince(t0));
  char head[80];
  std::snprintf(head, sizeof head, "{\"poses\": %d, \"paths\": %d, ", n, n * (n - 1));
  return std::string(head) + "\"library\": " + together.json() + ", \"one_plan_per_pair\": " + pairwise.json() + "}";
}

std::string benchMap(const MoveBaseConfig& config, const std::string& config_dir, const std::string& map_file) {
  const map::OccupancyMap m = map::loadMap(map_file);
  MoveBaseCore core(config);
  core.globalCostmap().layersOfType<StaticLayer>().front()->setMap(m);
  Stats global_update;
  auto t0 = Clock::now();
  core.globalCostmap().updateMap(Pose2D{});
  global_update.samples.push_back(msSince(t0));
  const CostGrid& costs = core.globalCostmap().costmap();
  // Free cells well away from obstacles (cost below the Burger's circumscribed cost).
  std::vector<Pose2D> free_poses;
  for (unsigned y = 0; y < costs.sizeY(); ++y)
    for (unsigned x = 0; x < costs.sizeX(); ++x)
      if (costs.cost(x, y) < 120 && m.at(x, y) == 0) {
        double wx, wy;
        costs.mapToWorld(x, y, wx, wy);
        free_poses.push_back({wx, wy, 0.0});
      }
  std::mt19937 rng(1);
  std::uniform_int_distribution<size_t> pick(0, free_poses.size() - 1);
  Stats planning;
  int planned = 0;
  double expansions = 0.0;
  constexpr int kPlans = 200;
  for (int i = 0; i < kPlans; ++i) {
    const Pose2D a = free_poses[pick(rng)], b = free_poses[pick(rng)];
    t0 = Clock::now();
    const PlanResult plan = core.makePlan(a, b, 0.0);
    planning.samples.push_back(msSince(t0));
    planned += plan.ok();
    expansions += core.planner().lastExpansions();
  }
  // Local costmap update (scan + inflation) and DWA cycles along planned paths.
  Stats local_update, control, global_incremental;
  ObstacleLayer* global_obstacles = core.globalCostmap().layersOfType<ObstacleLayer>().front();
  LocalController controller(config.dwa);
  ObstacleLayer* obstacles = core.localCostmap().layersOfType<ObstacleLayer>().front();
  const ObservationSourceConfig& source = obstacles->config().sources.front();
  int cycles = 0;
  for (int i = 0; i < 40 && cycles < 400; ++i) {
    const PlanResult plan = core.makePlan(free_poses[pick(rng)], free_poses[pick(rng)], 0.0);
    if (!plan.ok() || plan.path.size() < 20) continue;
    controller.setPlan(plan.path, LocalController::PlanUpdate::kNewRoute);
    for (size_t k = 0; k + 1 < plan.path.size() && cycles < 400; k += 8, ++cycles) {
      Pose2D pose = plan.path[k];
      pose.yaw = std::atan2(plan.path[k + 1].y - pose.y, plan.path[k + 1].x - pose.x);
      t0 = Clock::now();
      const LaserScanData scan = castScan(m, pose);
      const double cast_ms = msSince(t0);
      t0 = Clock::now();
      obstacles->addObservation(0, laserScanToObservation(scan, {pose.x, pose.y, 0.18, pose.yaw}, source));
      core.localCostmap().updateMap(pose);
      local_update.samples.push_back(msSince(t0));
      t0 = Clock::now();
      global_obstacles->addObservation(0, laserScanToObservation(scan, {pose.x, pose.y, 0.18, pose.yaw}, source));
      core.globalCostmap().updateMap(pose);
      global_incremental.samples.push_back(msSince(t0));
      (void)cast_ms;
      t0 = Clock::now();
      controller.computeVelocityCommands(core.localCostmap().costmap(), core.localCostmap().footprint(), pose,
                                         {0.15, 0.0, 0.0}, Transform2D{});
      control.samples.push_back(msSince(t0));
    }
  }
  char head[400];
  std::snprintf(head, sizeof head,
                "{\"map\": \"%s\", \"cells\": [%u, %u], \"plans_ok\": %d, \"plans\": %d, \"mean_expansions\": %.0f, ",
                map_file.c_str(), costs.sizeX(), costs.sizeY(), planned, kPlans, expansions / kPlans);
  // The travel binding on a costmap without the scans above (as it builds its own).
  MoveBaseCore fresh(config);
  fresh.globalCostmap().layersOfType<StaticLayer>().front()->setMap(m);
  fresh.globalCostmap().updateMap(Pose2D{});
  std::vector<Pose2D> inner_poses;
  for (const Pose2D& pose : free_poses) {
    unsigned mx, my;
    costs.worldToMap(pose.x, pose.y, mx, my);
    if (mx > 0 && my > 0 && mx + 1 < costs.sizeX() && my + 1 < costs.sizeY()) inner_poses.push_back(pose);
  }
  const std::string travel_10 = benchTravel(fresh, config_dir, map_file, inner_poses, 10, rng);
  const std::string travel_48 = benchTravel(fresh, config_dir, map_file, inner_poses, 48, rng);
  return std::string(head) + "\"planning\": " + planning.json() + ", \"global_costmap_full_update\": " +
         global_update.json() + ", \"global_costmap_update_with_scan\": " + global_incremental.json() +
         ", \"local_costmap_update\": " + local_update.json() +
         ", \"dwa_cycle\": " + control.json() + ", \"travel_10_poses\": " + travel_10 +
         ", \"travel_48_poses\": " + travel_48 + "}";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: bench_nav_core <config_dir> <map.yaml> [<map.yaml> ...]\n";
    return 2;
  }
  try {
    const MoveBaseConfig config = loadConfig(argv[1]);
    std::cout << "[";
    for (int i = 2; i < argc; ++i) std::cout << (i > 2 ? ",\n " : "") << benchMap(config, argv[1], argv[i]);
    std::cout << "]\n";
  } catch (const std::exception& error) {
    std::cerr << "bench_nav_core: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
