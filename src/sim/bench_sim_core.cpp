// Real-time factor of the simulator core alone (no ROS), on one core.
//
//   bench_sim_core <map.yaml> [robots...]   e.g. bench_sim_core maps/lab.yaml 2 4 8 16
//
// For each robot count: the sim seconds simulated per wall second and per CPU second (of this
// single thread, i.e. on one core) with the lidar at its rate, the same without the lidar
// (what is left is physics), and the share of time spent ray casting; each the best of
// kRepeats runs (other processes only ever slow a run down).
// Prints one JSON object per robot count, one per line (scripts/bench_sim reads them),
// including the start poses used, so that the node benchmark can use the same.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/sim/world.h"

namespace {

using marl_mrta::sim::Pose2D;
using marl_mrta::sim::Twist2D;
using marl_mrta::sim::World;
using marl_mrta::sim::WorldConfig;

constexpr double kPhysicsRate = 20.0;
constexpr double kScanRate = 5.0;
constexpr double kSimSeconds = 600.0;
constexpr int kRepeats = 3;

// Start poses spread over the free space: a coarse grid of points with room around them.
std::vector<Pose2D> spreadStartPoses(const marl_mrta::map::OccupancyMap& map, int robots) {
  WorldConfig probe_config;
  probe_config.start_poses = {Pose2D{}};
  std::vector<Pose2D> candidates;
  const marl_mrta::sim::ObstacleGrid grid(map);
  double x0, y0, x1, y1;
  map.cellToWorld(0, 0, x0, y0);
  map.cellToWorld(map.width - 1, map.height - 1, x1, y1);
  for (double y = y0 + 0.4; y < y1; y += 0.7) {
    for (double x = x0 + 0.4; x < x1; x += 0.7) {
      if (grid.isKnownFree(x, y) && grid.clearance(x, y, 0.35) >= 0.35) candidates.push_back({x, y, 0.0});
    }
  }
  if (static_cast<int>(candidates.size()) < robots) {
    std::fprintf(stderr, "bench_sim_core: only %zu free start places for %d robots\n", candidates.size(), robots);
    std::exit(1);
  }
  // Every k-th candidate, so that the robots spread over the whole map.
  std::vector<Pose2D> poses;
  const double stride = double(candidates.size()) / robots;
  for (int i = 0; i < robots; ++i) {
    Pose2D pose = candidates[static_cast<size_t>(i * stride)];
    pose.yaw = 0.7 * i;
    poses.push_back(pose);
  }
  return poses;
}

double cpuSeconds() {
  timespec now;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &now);
  return now.tv_sec + 1e-9 * now.tv_nsec;
}

struct RunTime {
  double wall = 1e9;  // [s]
  double cpu = 1e9;   // [s] of this thread on its core: what other processes do not inflate
};

// Time to simulate kSimSeconds with the given world configuration.
RunTime timeRun(const marl_mrta::map::OccupancyMap& map, const WorldConfig& config, long& ticks_out) {
  World world(map, config);
  const long ticks = static_cast<long>(kSimSeconds * config.physics_rate);
  const double cpu_start = cpuSeconds();
  const auto start = std::chrono::steady_clock::now();
  for (long t = 0; t < ticks; ++t) {
    if (t % 2 == 0) {  // controllers at 10 Hz, like move_base on a TurtleBot3
      for (int g = 0; g < world.robotCount(); ++g) {
        world.setCommand(g, Twist2D{0.22, 1.2 * std::sin(0.013 * t + g)});
      }
    }
    world.step();
  }
  ticks_out = ticks;
  return {std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), cpuSeconds() - cpu_start};
}

void keepBest(RunTime& best, const RunTime& run) {
  best.wall = std::min(best.wall, run.wall);
  best.cpu = std::min(best.cpu, run.cpu);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_sim_core <map.yaml> [robots...]\n");
    return 2;
  }
  marl_mrta::map::OccupancyMap map;
  try {
    map = marl_mrta::map::loadMap(argv[1]);
  } catch (const marl_mrta::map::MapError& e) {
    std::fprintf(stderr, "bench_sim_core: %s\n", e.what());
    return 1;
  }
  std::vector<int> robot_counts;
  for (int i = 2; i < argc; ++i) robot_counts.push_back(std::atoi(argv[i]));
  if (robot_counts.empty()) robot_counts = {2, 4, 8, 16};

  for (int robots : robot_counts) {
    WorldConfig config;
    config.start_poses = spreadStartPoses(map, robots);
    config.physics_rate = kPhysicsRate;
    config.scan_rate = kScanRate;
    config.odom_rate = kPhysicsRate;
    config.cmd_vel_timeout = 0.5;
    long ticks = 0;
    RunTime with_lidar, physics_only;
    for (int r = 0; r < kRepeats; ++r) {
      config.scan_rate = kScanRate;
      keepBest(with_lidar, timeRun(map, config, ticks));
      config.scan_rate = 0.0;
      keepBest(physics_only, timeRun(map, config, ticks));
    }
    // The split from CPU time, which other processes on the machine do not inflate.
    const double raycast = std::max(with_lidar.cpu - physics_only.cpu, 0.0);
    const long rays = static_cast<long>(kSimSeconds * kScanRate) * robots * 360;
    std::string poses;
    for (const Pose2D& pose : config.start_poses) {
      char entry[96];
      std::snprintf(entry, sizeof(entry), "%s[%.3f, %.3f, %.3f]", poses.empty() ? "" : ", ", pose.x, pose.y, pose.yaw);
      poses += entry;
    }
    std::printf(
        "{\"robots\": %d, \"sim_seconds\": %.1f, \"ticks\": %ld, \"wall_seconds\": %.4f, \"cpu_seconds\": %.4f, "
        "\"rtf\": %.1f, \"rtf_cpu\": %.1f, \"rtf_cpu_without_lidar\": %.1f, \"raycast_share\": %.3f, "
        "\"physics_share\": %.3f, \"ns_per_ray\": %.1f, \"us_per_tick\": %.3f, \"start_poses\": [%s]}\n",
        robots, kSimSeconds, ticks, with_lidar.wall, with_lidar.cpu, kSimSeconds / with_lidar.wall,
        kSimSeconds / with_lidar.cpu, kSimSeconds / physics_only.cpu, raycast / with_lidar.cpu,
        physics_only.cpu / with_lidar.cpu, raycast * 1e9 / rays, with_lidar.cpu * 1e6 / ticks, poses.c_str());
    std::fflush(stdout);
  }
  return 0;
}
