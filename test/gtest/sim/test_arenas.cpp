// Arenas share the map but nothing else: their robots neither see nor touch each other.
#include <gtest/gtest.h>

#include <cmath>

#include "marl_mrta/sim/world.h"
#include "sim_test_maps.h"

namespace marl_mrta {
namespace sim {
namespace {

using testing::idealConfig;
using testing::room;

TEST(Arenas, RobotsOfOtherArenasAreNeitherSeenNorTouched) {
  const map::OccupancyMap map = room(7.0, 5.0);
  World world(map, idealConfig({{1.0, 1.0, 0.0}, {1.0, 4.0, 0.0}}, 2));
  ASSERT_EQ(world.robotCount(), 4);
  // Arena 1's tb3_1 stands in the path of arena 0's tb3_0 (and 1.927 m in front of arena 1's tb3_0).
  ASSERT_EQ(world.reset(1, {{world.globalIndex(1, 1), {3.0, 1.0, M_PI / 2}}}), "");
  world.step();
  world.step();
  world.step();
  world.step();  // the next scan (5 Hz at 20 Hz physics)
  const float seen = world.robot(world.globalIndex(1, 0)).scan[0];
  EXPECT_NEAR(seen, 2.0 - 0.105 + 0.032, 1e-4);            // same arena: seen
  EXPECT_EQ(world.robot(world.globalIndex(0, 0)).scan[0], 0.0f);  // other arena: no return (wall 6 m away)

  int events = 0;
  for (int t = 0; t < 300; ++t) {  // 15 s at 0.22 m/s: straight through x = 3
    world.setCommand(world.globalIndex(0, 0), {0.22, 0.0});
    events += static_cast<int>(world.step().collisions.size());
  }
  EXPECT_EQ(events, 0);
  EXPECT_GT(world.robot(world.globalIndex(0, 0)).pose.x, 4.0);
  EXPECT_EQ(world.robot(world.globalIndex(1, 1)).pose.x, 3.0);
}

TEST(Arenas, AnArenaEvolvesExactlyAsItWouldAlone) {
  map::OccupancyMap map = room(7.0, 5.0);
  testing::addBox(map, 3.3, 2.0, 3.7, 2.4);
  WorldConfig config = idealConfig({{1.0, 1.0, 0.0}, {1.0, 4.0, 0.0}, {6.0, 2.5, M_PI}});
  config.noise = testing::noiseProfile("measured_tb3");
  config.seed = 5;
  auto command = [](int t, int i) {
    return Twist2D{0.22 * std::cos(t * 0.02 * (i + 1)), 1.5 * std::sin(t * 0.011 * (i + 3))};
  };
  World alone(map, config);
  config.arenas = 3;
  World shared(map, config);
  for (int t = 0; t < 800; ++t) {
    for (int i = 0; i < 3; ++i) {
      alone.setCommand(i, command(t, i));
      shared.setCommand(shared.globalIndex(0, i), command(t, i));
      // The other arenas do something else entirely.
      shared.setCommand(shared.globalIndex(1, i), {0.22, 0.0});
      shared.setCommand(shared.globalIndex(2, i), {-0.1, 2.0});
    }
    const StepReport& alone_report = alone.step();
    const size_t alone_events = alone_report.collisions.size();
    size_t shared_arena0_events = 0;
    for (const CollisionEvent& event : shared.step().collisions) shared_arena0_events += event.arena == 0;
    ASSERT_EQ(alone_events, shared_arena0_events) << "tick " << t;
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(alone.robot(i).pose.x, shared.robot(i).pose.x);
    EXPECT_EQ(alone.robot(i).pose.y, shared.robot(i).pose.y);
    EXPECT_EQ(alone.robot(i).odom_pose.x, shared.robot(i).odom_pose.x);
    EXPECT_EQ(alone.robot(i).scan, shared.robot(i).scan);
  }
}

TEST(Arenas, ResettingOneArenaLeavesTheOthersAlone) {
  const map::OccupancyMap map = room(7.0, 5.0);
  World world(map, idealConfig({{1.0, 1.0, 0.0}, {1.0, 4.0, 0.0}}, 2));
  testing::driveAll(world, {0.2, 0.0}, 40);
  const Pose2D arena0_robot0 = world.robot(world.globalIndex(0, 0)).pose;
  EXPECT_EQ(world.reset(1), "");
  EXPECT_EQ(world.robot(world.globalIndex(1, 0)).pose.x, 1.0);
  EXPECT_EQ(world.robot(world.globalIndex(0, 0)).pose.x, arena0_robot0.x);
  // Poses for a robot of another arena than the one reset are refused.
  EXPECT_NE(world.reset(1, {{world.globalIndex(0, 1), {2.0, 2.0, 0.0}}}).find("arena_0/tb3_1 is not in arena 1"),
            std::string::npos);
  EXPECT_EQ(robotNamespace({}, 2, 1, 0), "arena_1/tb3_0");
  EXPECT_EQ(robotNamespace({}, 1, 0, 3), "tb3_3");
  EXPECT_EQ(robotNamespace({"burger_a", "burger_b"}, 2, 1, 1), "arena_1/burger_b");
}

}  // namespace
}  // namespace sim
}  // namespace marl_mrta
