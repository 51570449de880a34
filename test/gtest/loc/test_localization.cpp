// The particle filter on the lab map, fed by the simulator core: a Burger with TurtleBot3's
// measured noise (odometry drift, lidar noise and dropout, latency, pauses) drives a round of
// the lab while the filter tracks it, finds it from a uniform spread, and recovers from a
// wrong initial pose. Several seeds each (noise and filter), so that no result rests on one
// lucky draw; every run is deterministic.
#include <gtest/gtest.h>

#include <cstring>

#include "loc_test_helpers.h"
#include "marl_mrta/nav/ground_truth_localization.h"

using namespace marl_mrta::loc;
using namespace marl_mrta::loc::testing;
namespace nav = marl_mrta::nav;

namespace {

constexpr int kSeeds = 5;

// A localizer with `config`, its filter started at `pose` with `covariance`, on `map`.
Localizer startedAt(AmclConfig config, const marl_mrta::map::OccupancyMap& map, const Pose2D& pose,
                    const PoseCovariance& covariance, int seed) {
  config.seed = seed;
  config.initial_pose = pose;
  config.initial_covariance = covariance;
  Localizer localizer(config);
  localizer.setMap(map);
  return localizer;
}

// Stock amcl's own defaults (laser limits from the scan), with the robot's frames.
AmclConfig stockDefaults() {
  YAML::Node tree(YAML::NodeType::Map);
  nav::setParam(tree, "odom_frame_id", YAML::Node("tb3_0/odom"));
  nav::setParam(tree, "base_frame_id", YAML::Node("tb3_0/base_footprint"));
  return readAmclConfig(nav::ParamNode(tree, "tb3_0/amcl"));
}

bool sameParticles(const std::vector<Particle>& a, const std::vector<Particle>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Particle)) == 0;
}

bool within(const Pose2D& estimate, const Pose2D& truth, double distance_limit, double yaw_limit) {
  return distance(estimate, truth) <= distance_limit && yawError(estimate.yaw, truth.yaw) <= yaw_limit;
}

}  // namespace

TEST(Localization, TracksARoundOfTheLabWithDriftingOdometry) {
  double largest_drift = 0.0;
  for (int seed = 0; seed < kSeeds; ++seed) {
    LabDrive lab(seed);
    const PoseCovariance tight{0.05 * 0.05, 0.0, 0.05 * 0.05, 0.05 * 0.05};
    Localizer localizer = startedAt(tb3Config(), lab.map(), lab.truth(), tight, seed);
    const std::vector<ScanStep> steps = lab.drive(localizer, labRound());
    // Dead reckoning from the start drifts beyond the tolerance: the filter keeps the pose.
    std::vector<ScanStep> dead_reckoning = steps;
    for (ScanStep& s : dead_reckoning) s.estimate = nav::Transform2D{0.5, 0.5, 0.0}.apply(s.odom);
    const Errors drift = worstErrors(dead_reckoning);
    const Errors errors = worstErrors(steps);
    size_t updates = 0;
    for (const ScanStep& s : steps) updates += s.outcome.used;
    std::printf("seed %d: %zu scans, %zu filter updates, worst error %.3f m / %.3f rad; odometry alone up to %.3f m / %.3f rad off\n",
                seed, steps.size(), updates, errors.position, errors.yaw, drift.position, drift.yaw);
    largest_drift = std::max(largest_drift, drift.position);
    EXPECT_GT(errors.checked, 400u);
    EXPECT_LE(errors.position, 0.10) << "seed " << seed;
    EXPECT_LE(errors.yaw, 0.10) << "seed " << seed;
  }
  // The drift is random: in some runs the odometry alone strays well beyond the tolerance.
  EXPECT_GT(largest_drift, 0.15);
}

TEST(Localization, RecoversFromAnInitialPoseHalfAMetreOff) {
  for (int seed = 0; seed < kSeeds; ++seed) {
    LabDrive lab(seed);
    const Pose2D wrong{lab.truth().x + 0.35, lab.truth().y + 0.35, lab.truth().yaw};  // 0.49 m off
    AmclConfig config = tb3Config();
    Localizer localizer = startedAt(config, lab.map(), wrong, config.initial_covariance, seed);
    const std::vector<ScanStep> steps = lab.drive(localizer, labRound());
    // From 6 s of driving on (about 1 m, five filter updates), the estimate stays within tolerance.
    size_t first_checked = 0;
    while (first_checked < steps.size() && steps[first_checked].time < 6.0) ++first_checked;
    EXPECT_GT(distance(steps.front().estimate, steps.front().truth), 0.25) << "seed " << seed;
    const Errors errors = worstErrors(steps, first_checked);
    EXPECT_GT(errors.checked, 400u);
    EXPECT_LE(errors.position, 0.10) << "seed " << seed;
    EXPECT_LE(errors.yaw, 0.10) << "seed " << seed;
  }
}

// The lab is point-symmetric about its centre: pose and twin (labTwin) see the same scans.
TEST(Localization, TheLabMapIsPointSymmetric) {
  const marl_mrta::map::OccupancyMap lab = labMap();
  for (int cy = 0; cy < lab.height; ++cy) {
    for (int cx = 0; cx < lab.width; ++cx) {
      ASSERT_EQ(lab.at(cx, cy), lab.at(lab.width - 1 - cx, lab.height - 1 - cy)) << cx << ", " << cy;
    }
  }
}

TEST(Localization, GlobalLocalizationOnTheLabEndsAtTheRobotOrItsTwin) {
  // Stock amcl's defaults: with TurtleBot3's (recovery off, a flat laser model, motion noise
  // alpha·δ² of millimetres per update) the spread collapses before it has found the robot in
  // about one run in five (docs/guide/navigation.md).
  int at_truth = 0;
  for (int seed = 0; seed < 2 * kSeeds; ++seed) {
    LabDrive lab(seed);
    Localizer localizer = startedAt(stockDefaults(), lab.map(), {}, {}, seed);
    localizer.globalLocalization();
    const std::vector<Particle>& spread = localizer.filter().particles();
    ASSERT_EQ(5000u, spread.size());
    const auto [min_x, max_x] = std::minmax_element(spread.begin(), spread.end(),
                                                    [](const Particle& a, const Particle& b) { return a.pose.x < b.pose.x; });
    EXPECT_GT(max_x->pose.x - min_x->pose.x, 6.5);  // over the whole lab
    const std::vector<ScanStep> steps = lab.drive(localizer, labRound());
    const ScanStep& last = steps.back();
    const bool truth = within(last.estimate, last.truth, 0.25, 0.25);
    EXPECT_TRUE(truth || within(last.estimate, labTwin(last.truth), 0.25, 0.25))
        << "seed " << seed << ": estimate (" << last.estimate.x << ", " << last.estimate.y << ", " << last.estimate.yaw
        << "), truth (" << last.truth.x << ", " << last.truth.y << ", " << last.truth.yaw << ")";
    at_truth += truth;
  }
  std::printf("global localisation on the lab: %d of %d runs at the robot, the others at its twin\n", at_truth, 2 * kSeeds);
}

TEST(Localization, GlobalLocalizationFindsTheRobotWhereTheLabIsNotSymmetric) {
  // A cabinet against the west wall, the robot starting beside it.
  const marl_mrta::map::OccupancyMap cabinet = labWithCabinet();
  int found = 0;
  for (int seed = 0; seed < 2 * kSeeds; ++seed) {
    LabDrive lab(seed, cabinet, {1.2, 2.5, M_PI});
    Localizer localizer = startedAt(stockDefaults(), lab.map(), {}, {}, seed);
    localizer.globalLocalization();
    std::vector<Pose2D> route = labRound();
    route.insert(route.begin(), Pose2D{1.2, 0.6, 0.0});
    const std::vector<ScanStep> steps = lab.drive(localizer, route);
    found += within(steps.back().estimate, steps.back().truth, 0.25, 0.25);
  }
  EXPECT_GE(found, 2 * kSeeds - 1);
}

TEST(Localization, KldShrinksTheSetAsTheFilterConverges) {
  LabDrive lab(0);
  AmclConfig config = tb3Config();
  Localizer localizer = startedAt(config, lab.map(), lab.truth(), config.initial_covariance, 0);
  localizer.globalLocalization();
  EXPECT_EQ(3000u, localizer.filter().particles().size());
  size_t largest = 0, smallest = 1u << 30;
  for (const Pose2D& waypoint : labRound()) {
    for (const ScanStep& s : lab.drive(localizer, {waypoint})) {
      if (!s.outcome.resampled) continue;
      const size_t count = localizer.filter().particles().size();
      ASSERT_GE(count, 500u);
      ASSERT_LE(count, 3000u);
      largest = std::max(largest, count);
      smallest = std::min(smallest, count);
    }
  }
  EXPECT_EQ(3000u, largest);  // while spread over the lab
  EXPECT_EQ(500u, smallest);  // converged: the minimum
  EXPECT_EQ(500u, localizer.filter().particles().size());
  EXPECT_LT(localizer.filter().binCount(), 60u);
}

TEST(Localization, SameSeedSameParticlesOtherSeedOthers) {
  const auto run = [](int filter_seed) {
    LabDrive lab(3);  // the same noise for all three
    AmclConfig config = tb3Config();
    Localizer localizer = startedAt(config, lab.map(), lab.truth(), config.initial_covariance, filter_seed);
    const std::vector<Pose2D> route = labRound();
    const std::vector<ScanStep> steps = lab.drive(localizer, {route[0], route[1], route[2]});
    return std::make_pair(localizer.filter().particles(), steps.back().outcome.map_to_odom.value());
  };
  const auto first = run(11), again = run(11), other = run(12);
  EXPECT_TRUE(sameParticles(first.first, again.first));
  EXPECT_EQ(0, std::memcmp(&first.second, &again.second, sizeof(nav::Transform2D)));
  EXPECT_FALSE(sameParticles(first.first, other.first));
}

TEST(Localization, MapToOdomPutsTheOdometryOnTheEstimate) {
  LabDrive lab(1);
  AmclConfig config = tb3Config();
  Localizer localizer = startedAt(config, lab.map(), lab.truth(), config.initial_covariance, 0);
  size_t estimates = 0;
  for (const ScanStep& s : lab.drive(localizer, {labRound()[0]})) {
    ASSERT_TRUE(s.outcome.map_to_odom.has_value());
    if (!s.outcome.new_estimate) continue;
    ++estimates;
    // map -> odom · odom -> base = map -> base (the estimate), at the scan's instant.
    const Pose2D base = s.outcome.map_to_odom->apply(s.odom);
    EXPECT_NEAR(s.outcome.estimate.pose.x, base.x, 1e-9);
    EXPECT_NEAR(s.outcome.estimate.pose.y, base.y, 1e-9);
    EXPECT_NEAR(0.0, yawError(s.outcome.estimate.pose.yaw, base.yaw), 1e-9);
    const nav::Transform2D same = nav::mapToOdom(nav::asTransform(s.outcome.estimate.pose), s.odom);
    EXPECT_EQ(0, std::memcmp(&same, &*s.outcome.map_to_odom, sizeof(same)));
  }
  EXPECT_GT(estimates, 5u);
}

TEST(Localization, UpdatesOnlyAfterMotionOrWhenAsked) {
  LabDrive lab(0, labMap(), {0.5, 0.5, 0.0}, "ideal");
  AmclConfig config = tb3Config();
  Localizer localizer = startedAt(config, lab.map(), lab.truth(), config.initial_covariance, 0);
  std::vector<ScanStep> still = lab.hold(localizer, 3.0);
  ASSERT_GT(still.size(), 10u);
  EXPECT_TRUE(still[0].outcome.used && still[0].outcome.new_estimate);  // the first scan after initialisation
  for (size_t i = 1; i < still.size(); ++i) EXPECT_FALSE(still[i].outcome.used) << i;
  localizer.requestNoMotionUpdate();
  still = lab.hold(localizer, 1.0);
  EXPECT_TRUE(still[0].outcome.used && still[0].outcome.resampled);
  for (size_t i = 1; i < still.size(); ++i) EXPECT_FALSE(still[i].outcome.used) << i;
  // Turning on the spot by more than update_min_a (0.2 rad) updates; less does not.
  const std::vector<ScanStep> turning = lab.hold(localizer, 0.8, 0.5);  // 0.4 rad
  size_t updates = 0;
  for (const ScanStep& s : turning) updates += s.outcome.used;
  EXPECT_EQ(1u, updates);
}

TEST(Localization, ScansBeforeTheMapAreIgnoredAndAnEarlyInitialPoseWaitsForIt) {
  LabDrive lab(0);
  Localizer localizer(tb3Config());
  const ScanOutcome before = localizer.processScan(lab.scan(), lab.odom());
  EXPECT_FALSE(before.used);
  EXPECT_FALSE(before.map_to_odom.has_value());
  EXPECT_EQ("no map yet", before.ignored_because);
  localizer.setInitialPose({2.0, 3.0, 1.0}, {0.01, 0.0, 0.01, 0.01});
  localizer.setMap(lab.map());
  EXPECT_NEAR(2.0, localizer.filter().mean().x, 0.02);
  EXPECT_NEAR(3.0, localizer.filter().mean().y, 0.02);
  EXPECT_NEAR(1.0, localizer.filter().mean().yaw, 0.02);
}

TEST(Localization, ANewMapStartsFromTheSavedPose) {
  LabDrive lab(0);
  AmclConfig config = tb3Config();
  Localizer localizer = startedAt(config, lab.map(), lab.truth(), config.initial_covariance, 0);
  lab.drive(localizer, {labRound()[0]});
  const std::optional<PoseEstimate> saved = localizer.savePose();
  ASSERT_TRUE(saved.has_value());
  localizer.setMap(lab.map());
  EXPECT_NEAR(saved->pose.x, localizer.filter().mean().x, 0.02);
  EXPECT_NEAR(saved->pose.y, localizer.filter().mean().y, 0.02);
}
