// The LDS-01 model: distances to walls, columns and robots; misses; noise and dropout.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "marl_mrta/sim/lidar.h"
#include "marl_mrta/sim/scan_caster.h"
#include "marl_mrta/sim/world.h"
#include "sim_test_maps.h"

namespace marl_mrta {
namespace sim {
namespace {

using testing::addBox;
using testing::addDisc;
using testing::kResolution;
using testing::room;

constexpr double kMountX = -0.032;  // base_scan behind the robot's centre

// Beam index pointing at `angle` in the robot frame (1 degree per beam from 0).
int beamAt(double angle_deg) { return static_cast<int>(std::lround(angle_deg)) % 360; }

std::vector<float> scanAt(const map::OccupancyMap& map, const Pose2D& pose, bool invalid_as_inf = false) {
  LidarSpec spec;
  spec.invalid_as_inf = invalid_as_inf;
  const Lidar lidar(spec);
  const ScanCaster caster(map);
  std::vector<float> ranges;
  lidar.castExact(caster, pose, {}, ranges);
  Rng rng(1);
  lidar.applyNoiseAndEncode(ranges, 0.0, 0.0, rng);
  return ranges;
}

// Reference: the first occupied cell square hit by the ray, by testing every occupied cell.
double bruteForceRay(const map::OccupancyMap& map, double x, double y, double dir_x, double dir_y, double max_range) {
  double best = std::numeric_limits<double>::infinity();
  for (int cy = 0; cy < map.height; ++cy) {
    for (int cx = 0; cx < map.width; ++cx) {
      if (map.at(cx, cy) != 100) continue;
      const double x0 = map.origin_x + cx * map.resolution, x1 = x0 + map.resolution;
      const double y0 = map.origin_y + cy * map.resolution, y1 = y0 + map.resolution;
      double t_min = 0.0, t_max = max_range;
      bool hit = true;
      for (int axis = 0; axis < 2 && hit; ++axis) {
        const double o = axis == 0 ? x : y, d = axis == 0 ? dir_x : dir_y;
        const double lo = axis == 0 ? x0 : y0, hi = axis == 0 ? x1 : y1;
        if (d == 0.0) {
          hit = o >= lo && o <= hi;
          continue;
        }
        double ta = (lo - o) / d, tb = (hi - o) / d;
        if (ta > tb) std::swap(ta, tb);
        t_min = std::max(t_min, ta);
        t_max = std::min(t_max, tb);
        hit = t_min <= t_max;
      }
      if (hit) best = std::min(best, t_min);
    }
  }
  return best;
}

TEST(Lidar, BeamsTowardWallsReturnTheirDistance) {
  const map::OccupancyMap map = room(5.0, 4.0);  // inner wall faces at x 0.05 / 4.95, y 0.05 / 3.95
  const Pose2D pose{2.5, 2.0, 0.0};
  const std::vector<float> ranges = scanAt(map, pose);
  ASSERT_EQ(ranges.size(), 360u);
  const double sensor_x = pose.x + kMountX;
  EXPECT_NEAR(ranges[beamAt(0)], 4.95 - sensor_x, kResolution);     // east wall
  EXPECT_NEAR(ranges[beamAt(90)], 3.95 - pose.y, kResolution);      // north wall
  EXPECT_NEAR(ranges[beamAt(270)], pose.y - 0.05, kResolution);     // south wall
  EXPECT_NEAR(ranges[beamAt(45)], (3.95 - pose.y) * std::sqrt(2.0), kResolution);  // north wall, diagonal
  // The walk is exact for axis-aligned faces, not merely within a cell.
  EXPECT_NEAR(ranges[beamAt(0)], 4.95 - sensor_x, 1e-5);
}

TEST(Lidar, RotatedRobotSeesTheSameWallsFromItsOwnFrame) {
  const map::OccupancyMap map = room(5.0, 4.0);
  const Pose2D pose{2.5, 2.0, M_PI / 2};  // facing north: the sensor sits 0.032 m south of the centre
  const std::vector<float> ranges = scanAt(map, pose);
  EXPECT_NEAR(ranges[beamAt(0)], 3.95 - (pose.y + kMountX), kResolution);  // north wall ahead
  EXPECT_NEAR(ranges[beamAt(90)], pose.x - 0.05, kResolution);            // west wall on the left
  EXPECT_NEAR(ranges[beamAt(270)], 4.95 - pose.x, kResolution);           // east wall on the right
}

TEST(Lidar, BeamTowardAColumnReturnsItsDistance) {
  map::OccupancyMap map = room(5.0, 6.0);
  addBox(map, 3.0, 1.8, 3.4, 2.2);    // square column 0.4 m, west face at x = 3.0, top face at y = 2.2
  addDisc(map, 2.0, 4.0, 0.2);        // round column of radius 0.2 m
  const Pose2D pose{2.0, 2.0, 0.0};
  const double sensor_x = pose.x + kMountX;
  const std::vector<float> ranges = scanAt(map, pose);
  EXPECT_NEAR(ranges[beamAt(0)], 3.0 - sensor_x, kResolution);
  // Straight north (from the sensor) to the round column, whose surface is 0.2 m below its centre.
  EXPECT_NEAR(ranges[beamAt(90)], (4.0 - 0.2) - pose.y, kResolution);
  // The first whole degree above the column's corner passes it and reaches the east wall.
  const double corner_deg = std::atan2(2.2 - pose.y, 3.0 - sensor_x) * 180.0 / M_PI;
  const int past_corner = static_cast<int>(std::ceil(corner_deg));
  EXPECT_NEAR(ranges[beamAt(past_corner)], (4.95 - sensor_x) / std::cos(past_corner * M_PI / 180.0), kResolution);
  EXPECT_NEAR(ranges[beamAt(past_corner - 1)], (3.0 - sensor_x) / std::cos((past_corner - 1) * M_PI / 180.0),
              kResolution);
}

TEST(Lidar, MissesReportNoReturnAsZeroOrInfinity) {
  const map::OccupancyMap map = room(12.0, 12.0);  // walls 6 m away: beyond the 3.5 m range
  const Pose2D pose{6.0, 6.0, 0.3};
  for (float range : scanAt(map, pose, false)) EXPECT_EQ(range, 0.0f);
  for (float range : scanAt(map, pose, true)) EXPECT_EQ(range, std::numeric_limits<float>::infinity());
}

TEST(Lidar, TooCloseReportsNoReturnAsZeroOrMinusInfinity) {
  const map::OccupancyMap map = room(3.0, 4.0);
  const Pose2D pose{0.05 + 0.106, 2.0, 0.0};  // touching the west wall; the sensor is 0.074 m from it
  EXPECT_EQ(scanAt(map, pose, false)[beamAt(180)], 0.0f);
  EXPECT_EQ(scanAt(map, pose, true)[beamAt(180)], -std::numeric_limits<float>::infinity());
  EXPECT_NEAR(scanAt(map, pose, false)[beamAt(0)], 2.95 - (pose.x + kMountX), kResolution);
}

TEST(Lidar, ScanCastingMatchesBruteForce) {
  // Whole scans from random poses in a cluttered map with an offset origin, beam by beam
  // against every occupied cell: merging cell borders into segments must lose nothing.
  map::OccupancyMap map = room(6.0, 5.0, -1.0, -0.5);
  Rng rng(7);
  for (int i = 0; i < 40; ++i) {
    const double x = rng.uniform(-0.8, 4.6), y = rng.uniform(-0.3, 4.1);
    addBox(map, x, y, x + rng.uniform(0.0, 0.5), y + rng.uniform(0.0, 0.3));
  }
  addBox(map, 1.0, 1.0, 1.05, 3.0);  // a one-cell-thin wall
  map.data[static_cast<size_t>(30) * map.width + 30] = 100;  // two cells touching at a corner only
  map.data[static_cast<size_t>(31) * map.width + 31] = 100;
  const ScanCaster caster(map);
  BeamFan fan;
  fan.count = 360;
  fan.increment = 2.0 * M_PI / 360;
  std::vector<float> ranges(360);
  int hits = 0, misses = 0;
  for (int scan = 0; scan < 30; ++scan) {
    // Some sensors stand outside the map, looking in.
    const Pose2D sensor{rng.uniform(-1.5, 5.5), rng.uniform(-1.0, 5.0), rng.uniform(-M_PI, M_PI)};
    int cx, cy;
    if (map.worldToCell(sensor.x, sensor.y, cx, cy) && map.at(cx, cy) == 100) continue;
    caster.cast(sensor, fan, 3.5, ranges.data());
    for (int i = 0; i < 360; ++i) {
      const double angle = sensor.yaw + i * fan.increment;
      const double reference = bruteForceRay(map, sensor.x, sensor.y, std::cos(angle), std::sin(angle), 3.5);
      if (std::isinf(reference)) {
        ++misses;
        EXPECT_TRUE(std::isinf(ranges[i])) << "scan " << scan << " beam " << i << ": " << ranges[i];
      } else {
        ++hits;
        EXPECT_NEAR(ranges[i], reference, 2e-6) << "scan " << scan << " beam " << i;
      }
    }
  }
  EXPECT_GT(hits, 5000);
  EXPECT_GT(misses, 100);
  EXPECT_GT(caster.segmentCount(), 100u);
}

TEST(Lidar, PartialFanDoesNotWrapAround) {
  const map::OccupancyMap map = room(5.0, 4.0);
  const ScanCaster caster(map);
  BeamFan fan;  // 90 degrees to the left only
  fan.count = 91;
  fan.angle_min = 0.0;
  fan.increment = M_PI / 180.0;
  std::vector<float> ranges(91);
  caster.cast({2.5, 2.0, 0.0}, fan, 3.5, ranges.data());
  EXPECT_NEAR(ranges[0], 2.45, 1e-6);   // east wall
  EXPECT_NEAR(ranges[90], 1.95, 1e-6);  // north wall
}

TEST(Lidar, RayCircleDistance) {
  const Circle circle{2.0, 0.0, 0.5};
  EXPECT_NEAR(rayCircleDistance(0.0, 0.0, 1.0, 0.0, circle), 1.5, 1e-12);
  EXPECT_TRUE(std::isinf(rayCircleDistance(0.0, 0.0, -1.0, 0.0, circle)));  // pointing away
  EXPECT_TRUE(std::isinf(rayCircleDistance(0.0, 1.0, 1.0, 0.0, circle)));   // passing above
  EXPECT_EQ(rayCircleDistance(2.1, 0.0, 1.0, 0.0, circle), 0.0);            // starting inside
}

TEST(Lidar, OtherRobotsOfTheArenaAreSeen) {
  const map::OccupancyMap map = room(8.0, 6.0);
  World world(map, testing::idealConfig({{2.0, 3.0, 0.0}, {3.0, 3.0, M_PI}}));
  const std::vector<float>& scan = world.robot(0).scan;
  // Robot 1's circle faces robot 0's sensor at 1.0 - 0.105 + 0.032 m.
  EXPECT_NEAR(scan[beamAt(0)], 1.0 - 0.105 - kMountX, 1e-4);
  const std::vector<float>& other_scan = world.robot(1).scan;
  EXPECT_NEAR(other_scan[beamAt(0)], 1.0 - 0.105 - kMountX, 1e-4);
  // Beams beside the robot pass it and reach the walls.
  EXPECT_NEAR(scan[beamAt(90)], 5.95 - 3.0, kResolution);
}

TEST(Lidar, DropoutAndNoiseFollowTheirParametersAndTheSeed) {
  const map::OccupancyMap map = room(5.0, 4.0);
  LidarSpec spec;
  const Lidar lidar(spec);
  const ScanCaster caster(map);
  std::vector<float> exact;
  lidar.castExact(caster, {2.5, 2.0, 0.0}, {}, exact);
  Rng rng(42);
  int dropped = 0, valid = 0;
  double sum_error = 0.0, sum_error_sq = 0.0;
  const int scans = 200;
  for (int s = 0; s < scans; ++s) {
    std::vector<float> ranges = exact;
    lidar.applyNoiseAndEncode(ranges, 0.01, 0.03, rng);
    for (size_t i = 0; i < ranges.size(); ++i) {
      if (ranges[i] == 0.0f) {
        ++dropped;
        continue;
      }
      ++valid;
      const double error = ranges[i] - exact[i];
      sum_error += error;
      sum_error_sq += error * error;
    }
  }
  const double dropout = double(dropped) / (scans * 360);
  EXPECT_NEAR(dropout, 0.03, 0.004);
  const double mean = sum_error / valid;
  EXPECT_NEAR(mean, 0.0, 0.001);
  EXPECT_NEAR(std::sqrt(sum_error_sq / valid - mean * mean), 0.01, 0.0005);

  std::vector<float> first = exact, again = exact, other_seed = exact;
  Rng a(5), b(5), c(6);
  lidar.applyNoiseAndEncode(first, 0.01, 0.03, a);
  lidar.applyNoiseAndEncode(again, 0.01, 0.03, b);
  lidar.applyNoiseAndEncode(other_seed, 0.01, 0.03, c);
  EXPECT_EQ(first, again);
  EXPECT_NE(first, other_seed);
}

TEST(Lidar, MeasuredProfileDropsTwoToFourPercent) {
  const map::OccupancyMap map = room(5.0, 4.0);
  WorldConfig config = testing::idealConfig({{2.5, 2.0, 0.0}});
  config.noise = testing::noiseProfile("measured_tb3");
  World world(map, config);
  int dropped = 0, readings = 0;
  for (int t = 0; t < 400; ++t) {
    if (world.step().scan_updated) {
      for (float range : world.robot(0).scan) dropped += range == 0.0f;
      readings += 360;
    }
  }
  ASSERT_EQ(readings, 100 * 360);  // 5 Hz scans at 20 Hz physics
  EXPECT_GT(double(dropped) / readings, 0.02);
  EXPECT_LT(double(dropped) / readings, 0.04);
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
