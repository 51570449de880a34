// The simulated world: K arenas sharing one static map, each with the same number of
// TurtleBot3 Burgers. Robots see and touch only the robots of their own arena.
//
// Time is a tick count advanced by step() (fixed step 1 / physics_rate); nothing here reads a
// clock, so the same commands at the same ticks always give the same result.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/param_error.h"
#include "marl_mrta/sim/geometry.h"
#include "marl_mrta/sim/lidar.h"
#include "marl_mrta/sim/obstacle_grid.h"
#include "marl_mrta/sim/random.h"
#include "marl_mrta/sim/robot_model.h"
#include "marl_mrta/sim/scan_caster.h"

namespace marl_mrta {
namespace sim {

// The name of robot `index` of an arena when none is configured: tb3_<index> (TurtleBot3's
// multi_robot_name convention).
std::string defaultRobotName(int index);

// Namespace of robot `index` of `arena`: its name (`names`, per arena; empty: defaultRobotName),
// prefixed arena_k/ when there are several arenas.
std::string robotNamespace(const std::vector<std::string>& names, int arenas, int arena, int index);

struct WorldConfig {
  int arenas = 1;
  std::vector<Pose2D> start_poses;  // one per robot of an arena (map frame)
  std::vector<std::string> robot_names;  // one per robot of an arena (messages); empty: tb3_0 ...
  double physics_rate = 20.0;       // [Hz] ticks per second of sim time
  double scan_rate = 5.0;           // [Hz] 0: no lidar
  double odom_rate = 20.0;          // [Hz] how often odometry is due for publishing
  double cmd_vel_timeout = 0.5;     // [s] stop when no command came for this long; 0: never
  RobotSpec robot;
  NoiseModel noise;
  uint64_t seed = 0;
};

struct RobotState {
  Pose2D pose;              // ground truth in the map frame
  Twist2D velocity;         // actual body velocity (what the wheels and odometry measure)
  Pose2D odom_pose;         // integrated from wheel motion since the last reset (odom frame)
  std::vector<float> scan;  // latest scan, encoded as LidarSpec says
  uint64_t scan_tick = 0;   // tick the scan was taken at
};

// One contact starting between a robot and a wall or another robot of its arena.
struct CollisionEvent {
  uint64_t tick = 0;
  double time = 0.0;      // [s] sim time
  int arena = 0;
  int robot = 0;          // index within the arena
  int other_robot = -1;   // index within the arena, or kWall
  Point2D contact;        // map frame
  static constexpr int kWall = -1;
};

struct StepReport {
  bool scan_updated = false;  // every robot's scan was taken at this tick
  bool odom_due = false;      // odometry (and ground truth) are due for publishing
  std::vector<CollisionEvent> collisions;
};

class World {
 public:
  // Throws nav::ParamError naming the setting (e.g. "start_poses[1]") when the configuration or
  // a start pose is unusable.
  World(const map::OccupancyMap& map, const WorldConfig& config);

  int arenaCount() const { return config_.arenas; }
  int robotsPerArena() const { return robots_per_arena_; }
  int robotCount() const { return static_cast<int>(robots_.size()); }
  // Robots are numbered arena by arena: global index = arena * robotsPerArena() + index.
  int globalIndex(int arena, int index) const { return arena * robots_per_arena_ + index; }

  uint64_t tick() const { return tick_; }
  double time() const { return tick_ / config_.physics_rate; }
  double timeStep() const { return 1.0 / config_.physics_rate; }
  const WorldConfig& config() const { return config_; }
  const ObstacleGrid& obstacles() const { return grid_; }

  const RobotState& robot(int global_index) const { return robots_.at(global_index).state; }
  const Pose2D& startPose(int global_index) const { return robots_.at(global_index).start_pose; }

  // The velocity command a robot's base receives now (latest wins). Returns false (and ignores
  // the command) when a component is not finite.
  bool setCommand(int global_index, const Twist2D& command);

  // Advances one tick: commands, limits, motion, collisions, odometry, then sensors.
  const StepReport& step();

  // Puts the robots of `arena` (-1: every arena) back to their start poses: velocities zero,
  // odometry restarted, pending commands dropped. `new_start_poses` first replaces the start
  // poses of the given robots (global indices), which must lie in the reset arena(s).
  // `episode_seed`, when given, restarts the reset robots' noise streams from it (combined
  // with the configured seed), so an episode's noise does not depend on how many ticks ran
  // before it; without it the streams run on.
  // Returns "" on success, else a one-line reason and changes nothing.
  std::string reset(int arena, const std::vector<std::pair<int, Pose2D>>& new_start_poses = {},
                    std::optional<uint64_t> episode_seed = std::nullopt);

  // Whether something at `rate` [Hz] is due at `tick` of a physics at `physics_rate`: on the
  // ticks at which the count of its periods goes up (exact for rates dividing physics_rate).
  static bool due(uint64_t tick, double rate, double physics_rate);

  // Why a robot of `arena` could not stand at `pose` given the other poses of the arena
  // (skip_index: the robot itself), or "" if it can.
  std::string placementProblem(const Pose2D& pose, const std::vector<Pose2D>& arena_poses, int skip_index) const;

 private:
  struct PendingCommand {
    uint64_t apply_tick;
    Twist2D command;
  };
  struct Robot {
    RobotState state;
    Pose2D start_pose;
    Twist2D target;                      // command the base is following
    Twist2D drive;                       // velocity the wheel controller reached (acceleration-limited)
    uint64_t last_command_tick = 0;      // tick the target was last set
    std::deque<PendingCommand> pending;  // commands still travelling (latency)
    uint64_t paused_until_tick = 0;
    bool wall_contact = false;
    std::vector<int> robot_contacts;     // indices within the arena
    Rng motion_rng, lidar_rng;
  };

  void updateTarget(Robot& robot);
  void moveRobot(int global_index);
  // Wall or robot (index within the arena) the robot would overlap at `pose`; -2: nothing.
  int blockingParty(int global_index, const Pose2D& pose) const;
  void addContact(int global_index, int party, const Pose2D& pose);
  void releaseContacts(int global_index);
  void integrateOdometry(Robot& robot, const Twist2D& velocity, double dt);
  void takeScans();
  void resetRobot(Robot& robot);
  void seedStreams(int global_index, uint64_t seed);

  WorldConfig config_;
  ObstacleGrid grid_;
  ScanCaster scan_caster_;
  Lidar lidar_;
  int robots_per_arena_ = 0;
  std::vector<Robot> robots_;
  uint64_t tick_ = 0;
  StepReport report_;
  std::vector<Circle> circles_;  // scratch: the other robots of an arena
};

}  // namespace sim
}  // namespace marl_mrta
