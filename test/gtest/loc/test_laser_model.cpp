// The map part (obstacle distances, free cells) and the likelihood-field laser model: which
// readings count, how beams are subsampled, and that the true pose scores best.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "loc_test_helpers.h"
#include "marl_mrta/sim/lidar.h"
#include "marl_mrta/sim/scan_caster.h"

using namespace marl_mrta::loc;
using namespace marl_mrta::loc::testing;
namespace map = marl_mrta::map;
namespace sim = marl_mrta::sim;

namespace {

// A scan of `count` readings over a full turn, all `range`.
ScanObservation uniformScan(int count, float range) {
  ScanObservation scan;
  scan.angle_increment = 2.0 * M_PI / count;
  scan.range_min = 0.12;
  scan.range_max = 3.5;
  scan.ranges.assign(static_cast<size_t>(count), range);
  return scan;
}

// The LDS-01 scan the simulator core ray-casts (exact, no noise) for a Burger at `pose`.
ScanObservation castScan(const map::OccupancyMap& occupancy, const Pose2D& pose) {
  const sim::ScanCaster caster(occupancy);
  const sim::Lidar lidar(sim::LidarSpec{});
  ScanObservation scan;
  scan.laser_x = lidar.spec().mount_x;
  scan.angle_increment = lidar.spec().angleIncrement();
  scan.range_min = lidar.spec().range_min;
  scan.range_max = lidar.spec().range_max;
  std::vector<float> ranges;
  lidar.castExact(caster, {pose.x, pose.y, pose.yaw}, {}, ranges);
  for (float& r : ranges) {
    if (!std::isfinite(r)) r = 0.0f;  // no return, as the driver reports it
  }
  scan.ranges = ranges;
  return scan;
}

double likelihoodAt(LikelihoodFieldModel& model, const ScanObservation& scan, const Pose2D& pose) {
  std::vector<Particle> one{{pose, 1.0}};
  EXPECT_TRUE(model.weigh(scan, one));
  return one[0].weight;
}

}  // namespace

TEST(LocalizationMap, DistancesAreExactEuclideanBetweenCellCentres) {
  // A random sprinkle of obstacles and unknown cells; brute force as the reference.
  map::OccupancyMap occupancy;
  occupancy.resolution = 0.1;
  occupancy.width = 37;
  occupancy.height = 23;
  occupancy.data.assign(static_cast<size_t>(occupancy.width) * occupancy.height, map::OccupancyMap::kFree);
  RandomSource rng(5);
  for (int8_t& cell : occupancy.data) {
    const double u = rng.uniform();
    cell = u < 0.03 ? map::OccupancyMap::kOccupied : (u < 0.06 ? map::OccupancyMap::kUnknown : cell);
  }
  const double cap = 1.2;
  const LocalizationMap localization(occupancy, cap);
  for (int y = 0; y < occupancy.height; ++y) {
    for (int x = 0; x < occupancy.width; ++x) {
      double nearest = std::numeric_limits<double>::infinity();
      for (int oy = 0; oy < occupancy.height; ++oy) {
        for (int ox = 0; ox < occupancy.width; ++ox) {
          if (occupancy.at(ox, oy) == map::OccupancyMap::kOccupied) nearest = std::min(nearest, std::hypot(ox - x, oy - y) * 0.1);
        }
      }
      ASSERT_NEAR(std::min(cap, nearest), localization.obstacleDistance(static_cast<size_t>(y) * occupancy.width + x), 1e-6)
          << "cell (" << x << ", " << y << ")";
    }
  }
}

TEST(LocalizationMap, LabDistancesOffTheMapAndFreeCells) {
  const LocalizationMap lab(labMap(), 2.0);
  // 0.55 m from the west wall's inner cells (centres at x = -0.025), nothing nearer.
  EXPECT_NEAR(0.55, lab.obstacleDistanceAt(0.53, 0.9), 1e-6);
  EXPECT_NEAR(0.0, lab.obstacleDistanceAt(-0.05, 2.0), 1e-9);  // inside the wall
  EXPECT_DOUBLE_EQ(2.0, lab.obstacleDistanceAt(20.0, 20.0));    // off the map: as far as the field goes
  const LocalizationMap capped(labMap(), 0.5);
  EXPECT_NEAR(0.5, capped.obstacleDistanceAt(0.53, 0.9), 1e-6);
  // Random poses lie on free cells, anywhere within them, headings over the whole turn.
  RandomSource rng(1);
  const map::OccupancyMap& grid = lab.occupancy();
  double min_yaw = 0.0, max_yaw = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const Pose2D pose = lab.randomFreePose(rng);
    int cx, cy;
    ASSERT_TRUE(grid.worldToCell(pose.x, pose.y, cx, cy));
    ASSERT_EQ(map::OccupancyMap::kFree, grid.at(cx, cy));
    min_yaw = std::min(min_yaw, pose.yaw);
    max_yaw = std::max(max_yaw, pose.yaw);
  }
  EXPECT_LT(min_yaw, -3.1);
  EXPECT_GT(max_yaw, 3.1);
  EXPECT_GT(lab.freeCellCount(), 12000u);
}

TEST(LocalizationMap, SaysWhereARobotCannotStand) {
  map::OccupancyMap grid = labMap();
  grid.data[0] = map::OccupancyMap::kUnknown;  // the corner cell (-0.5 .. -0.45, -0.5 .. -0.45)
  const LocalizationMap lab(grid, 2.0);
  EXPECT_EQ("", lab.standingProblem(0.5, 0.5));  // the first start pose
  EXPECT_EQ("is inside an obstacle of the map", lab.standingProblem(1.75, 1.5));  // a column
  EXPECT_EQ("is on an unknown cell of the map", lab.standingProblem(-0.49, -0.49));
  EXPECT_EQ("is off the map (x in [-0.50, 7.50], y in [-0.50, 5.50])", lab.standingProblem(9.0, 2.0));
  EXPECT_EQ("is off the map (x in [-0.50, 7.50], y in [-0.50, 5.50])", lab.standingProblem(0.5, -0.51));
}

TEST(LikelihoodFieldModel, NoReturnsAndOutOfRangeReadingsAreSkipped) {
  const LocalizationMap lab(labMap(), 2.0);
  LaserModelParams params;
  params.max_beams = 180;
  params.max_range = 3.0;  // narrows the scan's 3.5 m
  LikelihoodFieldModel model(params, lab);
  ScanObservation scan = uniformScan(360, 1.0f);
  scan.ranges[0] = 0.0f;                                       // no return (LDS-01 driver)
  scan.ranges[2] = 0.10f;                                      // below range_min
  scan.ranges[4] = 3.2f;                                       // beyond laser_max_range
  scan.ranges[6] = std::numeric_limits<float>::quiet_NaN();
  scan.ranges[8] = std::numeric_limits<float>::infinity();
  scan.ranges[10] = 3.0f;                                      // at the maximum: no return either
  scan.ranges[1] = 0.0f;                                       // odd readings are not among the 180 used
  const std::vector<int> used = model.usedBeams(scan);
  EXPECT_EQ(174u, used.size());
  for (int skipped : {0, 2, 4, 6, 8, 10}) EXPECT_EQ(used.end(), std::find(used.begin(), used.end(), skipped));
  EXPECT_EQ(12, used.front());
  EXPECT_EQ(358, used.back());
  // A scan of nothing but no-returns says nothing: every weight stays (1 + an empty sum).
  EXPECT_DOUBLE_EQ(1.0, likelihoodAt(model, uniformScan(360, 0.0f), {3.0, 2.0, 0.0}));
  // Unusable limits: the scan is refused, weights untouched.
  ScanObservation broken = uniformScan(360, 1.0f);
  broken.range_max = 0.0;
  LaserModelParams unlimited;
  LikelihoodFieldModel plain(unlimited, lab);
  std::vector<Particle> particles{{{3.0, 2.0, 0.0}, 0.5}};
  EXPECT_FALSE(plain.weigh(broken, particles));
  EXPECT_DOUBLE_EQ(0.5, particles[0].weight);
}

TEST(LikelihoodFieldModel, UsesEvenlySpacedBeamsLikeAmcl) {
  const LocalizationMap lab(labMap(), 2.0);
  LaserModelParams params;
  params.max_beams = 30;  // step (360 - 1) / (30 - 1) = 12
  LikelihoodFieldModel model(params, lab);
  const std::vector<int> used = model.usedBeams(uniformScan(360, 1.0f));
  ASSERT_EQ(30u, used.size());
  for (size_t i = 0; i < used.size(); ++i) EXPECT_EQ(static_cast<int>(12 * i), used[i]);
  params.max_beams = 500;  // more than there are: every reading
  LikelihoodFieldModel every(params, lab);
  EXPECT_EQ(360u, every.usedBeams(uniformScan(360, 1.0f)).size());
}

TEST(LikelihoodFieldModel, ScoresTheTruePoseAboveNearbyOnes) {
  const map::OccupancyMap occupancy = labMap();
  const LocalizationMap lab(occupancy, 2.0);
  LaserModelParams params = tb3Config().laser;
  LikelihoodFieldModel model(params, lab);
  const Pose2D truth{1.2, 1.0, 0.3};
  const ScanObservation scan = castScan(occupancy, truth);
  const double at_truth = likelihoodAt(model, scan, truth);
  // Every used beam ends on a wall: at the true pose each scores (z_hit + z_rand / range_max)³.
  const double per_beam = std::pow(params.z_hit + params.z_rand / 3.5, 3);
  EXPECT_GT(at_truth, 1.0 + 0.9 * model.usedBeams(scan).size() * per_beam);
  for (const Pose2D& other : {Pose2D{1.3, 1.0, 0.3}, Pose2D{1.2, 0.9, 0.3}, Pose2D{1.2, 1.0, 0.4}, Pose2D{1.7, 1.3, 0.3},
                              Pose2D{1.2, 1.0, -0.3}}) {
    EXPECT_LT(likelihoodAt(model, scan, other), at_truth) << other.x << " " << other.y << " " << other.yaw;
  }
  // The laser sits 0.032 m behind the base: ignoring the mount costs likelihood too.
  ScanObservation unmounted = scan;
  unmounted.laser_x = 0.0;
  EXPECT_LT(likelihoodAt(model, unmounted, truth), at_truth);
}
