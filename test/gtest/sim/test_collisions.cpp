// Collisions: robots stop without overlapping walls or each other, and a contact is reported
// once when it starts.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "marl_mrta/sim/world.h"
#include "sim_test_maps.h"

namespace marl_mrta {
namespace sim {
namespace {

using testing::idealConfig;
using testing::room;

constexpr double kRadius = 0.105;
constexpr double kEastWallFace = 4.95;  // room(5, 4)

std::vector<CollisionEvent> driveCollecting(World& world, const std::vector<Twist2D>& commands, int ticks,
                                            const std::function<void(const World&)>& check = {}) {
  std::vector<CollisionEvent> events;
  for (int t = 0; t < ticks; ++t) {
    for (size_t g = 0; g < commands.size(); ++g) world.setCommand(static_cast<int>(g), commands[g]);
    const StepReport& report = world.step();
    events.insert(events.end(), report.collisions.begin(), report.collisions.end());
    if (check) check(world);
  }
  return events;
}

TEST(Collisions, RobotDrivenIntoAWallStopsBeforeOverlappingWithOneEvent) {
  const map::OccupancyMap map = room(5.0, 4.0);
  World world(map, idealConfig({{4.0, 2.0, 0.0}}));
  double closest = 1e9;
  const auto events = driveCollecting(world, {{0.22, 0.0}}, 100, [&](const World& w) {
    const Pose2D& pose = w.robot(0).pose;
    closest = std::min(closest, kEastWallFace - pose.x);
    ASSERT_GE(w.obstacles().clearance(pose.x, pose.y, 1.0), kRadius) << "overlap at tick " << w.tick();
  });
  // It got to the wall (within a millimetre) and no further.
  EXPECT_GE(closest, kRadius);
  EXPECT_LT(closest, kRadius + 1e-3);
  EXPECT_EQ(world.robot(0).velocity.linear, 0.0);
  ASSERT_EQ(events.size(), 1u);
  const CollisionEvent& event = events[0];
  EXPECT_EQ(event.arena, 0);
  EXPECT_EQ(event.robot, 0);
  EXPECT_EQ(event.other_robot, CollisionEvent::kWall);
  EXPECT_NEAR(event.contact.x, kEastWallFace, 1e-6);
  EXPECT_NEAR(event.contact.y, 2.0, 1e-6);
  // (4.95 - 0.105 - 4.0) / 0.22 s after the start plus the 0.05 s of acceleration ramp, at 20 Hz.
  EXPECT_NEAR(event.time, (kEastWallFace - kRadius - 4.0) / 0.22 + 0.022, 0.05);
  EXPECT_EQ(event.time, event.tick / 20.0);
}

TEST(Collisions, LeavingAndHittingAgainIsANewEvent) {
  const map::OccupancyMap map = room(5.0, 4.0);
  World world(map, idealConfig({{4.5, 2.0, 0.0}}));
  EXPECT_EQ(driveCollecting(world, {{0.22, 0.0}}, 40).size(), 1u);    // hits, keeps pushing
  EXPECT_EQ(driveCollecting(world, {{-0.22, 0.0}}, 20).size(), 0u);   // backs off 0.2 m
  EXPECT_EQ(driveCollecting(world, {{0.22, 0.0}}, 40).size(), 1u);    // hits again
}

TEST(Collisions, PushingAndTurningAgainstAColumnNeverOverlaps) {
  map::OccupancyMap map = room(5.0, 4.0);
  testing::addDisc(map, 2.5, 2.0, 0.2);  // a round column, hit off-centre
  World world(map, idealConfig({{1.8, 2.25, 0.0}}));
  auto no_overlap = [&](const World& w) {
    const Pose2D& pose = w.robot(0).pose;
    ASSERT_GE(w.obstacles().clearance(pose.x, pose.y, 1.0), kRadius) << "overlap at tick " << w.tick();
  };
  const auto hit = driveCollecting(world, {{0.22, 0.0}}, 60, no_overlap);
  ASSERT_EQ(hit.size(), 1u);
  EXPECT_GT(hit[0].contact.y, 2.0);  // on the column's upper half
  EXPECT_LT(hit[0].contact.x, 2.5);
  const Pose2D at_contact = world.robot(0).pose;
  driveCollecting(world, {{0.22, -0.8}}, 140, no_overlap);  // keep pushing while turning into it
  driveCollecting(world, {{0.22, 0.8}}, 140, no_overlap);   // and away from it
  EXPECT_GT(std::hypot(world.robot(0).pose.x - at_contact.x, world.robot(0).pose.y - at_contact.y), 0.1);
}

TEST(Collisions, TwoRobotsHeadOnStopAndBothEventsAreEmitted) {
  const map::OccupancyMap map = room(6.0, 4.0);
  World world(map, idealConfig({{2.0, 2.0, 0.0}, {4.0, 2.0, M_PI}}));
  double closest = 1e9;
  const auto events = driveCollecting(world, {{0.22, 0.0}, {0.22, 0.0}}, 120, [&](const World& w) {
    const double gap = std::hypot(w.robot(1).pose.x - w.robot(0).pose.x, w.robot(1).pose.y - w.robot(0).pose.y);
    closest = std::min(closest, gap);
    ASSERT_GE(gap, 2 * kRadius) << "overlap at tick " << w.tick();
  });
  EXPECT_LT(closest, 2 * kRadius + 1e-3);
  EXPECT_EQ(world.robot(0).velocity.linear, 0.0);
  EXPECT_EQ(world.robot(1).velocity.linear, 0.0);
  ASSERT_EQ(events.size(), 2u);
  // One event per robot, each naming the other, at the same tick.
  EXPECT_EQ(events[0].robot + events[1].robot, 1);
  EXPECT_EQ(events[0].other_robot, 1 - events[0].robot);
  EXPECT_EQ(events[1].other_robot, 1 - events[1].robot);
  EXPECT_EQ(events[0].tick, events[1].tick);
  // The contact point lies between the two robots.
  const double middle = 0.5 * (world.robot(0).pose.x + world.robot(1).pose.x);
  EXPECT_NEAR(events[0].contact.x, middle, 1e-3);
  EXPECT_NEAR(events[0].contact.y, 2.0, 1e-9);
  // The robots met near the middle (each drove the same distance, give or take one tick).
  EXPECT_NEAR(world.robot(0).pose.x - 2.0, 4.0 - world.robot(1).pose.x, 0.22 / 20 + 1e-6);
}

TEST(Collisions, RobotIntoAStandingRobotStopsAndBothGetAnEvent) {
  const map::OccupancyMap map = room(6.0, 4.0);
  World world(map, idealConfig({{2.0, 2.0, 0.0}, {3.0, 2.0, M_PI / 2}}));
  const auto events = driveCollecting(world, {{0.22, 0.0}, {0.0, 0.0}}, 120);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].robot, 0);
  EXPECT_EQ(events[0].other_robot, 1);
  EXPECT_EQ(events[1].robot, 1);
  EXPECT_EQ(events[1].other_robot, 0);
  EXPECT_NEAR(world.robot(1).pose.x - world.robot(0).pose.x, 2 * kRadius, 1e-3);
  EXPECT_EQ(world.robot(1).pose.x, 3.0);  // the standing robot is not pushed
}

TEST(Collisions, StartPosesInsideObstaclesOrOverlappingAreRejected) {
  map::OccupancyMap map = room(7.0, 5.0);
  testing::addBox(map, 1.55, 1.3, 1.95, 1.7);  // a column around (1.75, 1.5)
  try {
    World world(map, idealConfig({{0.5, 0.5, 0.0}, {1.75, 1.5, 0.0}}));
    FAIL() << "a start pose inside a column was accepted";
  } catch (const nav::ParamError& e) {
    EXPECT_EQ(e.where(), "start_poses[1]");
    EXPECT_NE(e.problem().find("overlaps an obstacle"), std::string::npos) << e.what();
  }
  try {
    World world(map, idealConfig({{0.5, 0.5, 0.0}, {0.6, 0.5, 0.0}}));
    FAIL() << "overlapping start poses were accepted";
  } catch (const nav::ParamError& e) {
    EXPECT_EQ(e.where(), "start_poses[0]");
    EXPECT_NE(e.problem().find("overlaps robot 1"), std::string::npos) << e.what();
  }
  try {
    World world(map, idealConfig({{-3.0, 0.5, 0.0}}));
    FAIL() << "a start pose outside the map was accepted";
  } catch (const nav::ParamError& e) {
    EXPECT_NE(e.problem().find("not on a known free cell"), std::string::npos) << e.what();
  }
}

TEST(Reset, RestoresStartPosesAndRestartsOdometry) {
  const map::OccupancyMap map = room(6.0, 4.0);
  World world(map, idealConfig({{1.0, 1.0, 0.0}, {1.0, 3.0, 0.0}}));
  testing::driveAll(world, {0.2, 0.5}, 60);
  ASSERT_GT(std::abs(world.robot(0).pose.x - 1.0), 0.1);
  EXPECT_EQ(world.reset(-1), "");
  for (int g = 0; g < 2; ++g) {
    EXPECT_EQ(world.robot(g).pose.x, world.startPose(g).x);
    EXPECT_EQ(world.robot(g).pose.y, world.startPose(g).y);
    EXPECT_EQ(world.robot(g).odom_pose.x, 0.0);
    EXPECT_EQ(world.robot(g).velocity.linear, 0.0);
  }
  // Given poses become the new start poses; a bad one changes nothing.
  EXPECT_EQ(world.reset(-1, {{1, {4.0, 2.0, 1.0}}}), "");
  EXPECT_EQ(world.robot(1).pose.x, 4.0);
  EXPECT_EQ(world.startPose(1).yaw, 1.0);
  const std::string problem = world.reset(-1, {{0, {0.05, 2.0, 0.0}}});
  EXPECT_NE(problem.find("tb3_0: robot at (0.050, 2.000, 0.000) overlaps an obstacle"), std::string::npos) << problem;
  EXPECT_EQ(world.startPose(0).x, 1.0);
  EXPECT_NE(world.reset(3), "");  // no such arena
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
