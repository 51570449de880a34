#include "marl_mrta/sim/world.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "marl_mrta/sim/diff_drive.h"

namespace marl_mrta {
namespace sim {

namespace {

constexpr int kNobody = -2;
// A contact ends once the gap has opened by this much (no flurry of events while touching).
constexpr double kContactReleaseGap = 0.01;  // [m]
// Bisection steps locating the contact within a tick (2^-20 of a step: about 0.01 micron).
constexpr int kContactBisections = 20;

std::string formatPose(const Pose2D& pose) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(3);
  out << "(" << pose.x << ", " << pose.y << ", " << pose.yaw << ")";
  return out.str();
}

void requirePositive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    std::ostringstream out;
    out << "must be a positive number, got " << value;
    throw nav::ParamError(field, out.str());
  }
}

void requireRange(double value, double low, double high, const char* field) {
  if (!(value >= low && value <= high)) {
    std::ostringstream out;
    out << "must be in [" << low << ", " << high << "], got " << value;
    throw nav::ParamError(field, out.str());
  }
}

// The configuration itself, once checked (so that the members built from it are sound).
const WorldConfig& validated(const WorldConfig& config) {
  if (config.arenas < 1) throw nav::ParamError("arenas", "must be at least 1, got " + std::to_string(config.arenas));
  if (config.start_poses.empty()) throw nav::ParamError("start_poses", "no robots: give at least one start pose");
  requirePositive(config.physics_rate, "physics_rate");
  requireRange(config.scan_rate, 0.0, config.physics_rate, "scan_rate");
  requirePositive(config.odom_rate, "odom_rate");
  requireRange(config.odom_rate, 0.0, config.physics_rate, "odom_rate");
  requireRange(config.cmd_vel_timeout, 0.0, 1e9, "cmd_vel_timeout");
  const RobotSpec& robot = config.robot;
  requirePositive(robot.radius, "robot_radius");
  requirePositive(robot.limits.max_linear_velocity, "max_linear_velocity");
  requirePositive(robot.limits.max_angular_velocity, "max_angular_velocity");
  requirePositive(robot.limits.max_linear_acceleration, "max_linear_acceleration");
  requirePositive(robot.limits.max_angular_acceleration, "max_angular_acceleration");
  if (robot.lidar.beams < 1) throw nav::ParamError("lidar_beams", "must be at least 1");
  requirePositive(robot.lidar.range_max, "lidar_range_max");
  requireRange(robot.lidar.range_min, 0.0, robot.lidar.range_max, "lidar_range_min");
  const NoiseModel& noise = config.noise;
  requirePositive(noise.linear_speed_scale, "noise.linear_speed_scale");
  requireRange(noise.command_latency_min, 0.0, 10.0, "noise.command_latency_min");
  requireRange(noise.command_latency_max, noise.command_latency_min, 10.0, "noise.command_latency_max");
  requireRange(noise.pause_rate, 0.0, 1e3, "noise.pause_rate");
  requireRange(noise.pause_duration_min, 0.0, 1e3, "noise.pause_duration_min");
  requireRange(noise.pause_duration_max, noise.pause_duration_min, 1e3, "noise.pause_duration_max");
  requireRange(noise.lidar_range_stddev, 0.0, 10.0, "noise.lidar_range_stddev");
  requireRange(noise.lidar_dropout_min, 0.0, 1.0, "noise.lidar_dropout_min");
  requireRange(noise.lidar_dropout_max, noise.lidar_dropout_min, 1.0, "noise.lidar_dropout_max");
  requireRange(noise.odom_translation_stddev, 0.0, 10.0, "noise.odom_translation_stddev");
  requireRange(noise.odom_rotation_stddev, 0.0, 10.0, "noise.odom_rotation_stddev");
  return config;
}

// Independent random streams per robot and purpose, so that one robot's noise never depends
// on what another robot (or another arena) did.
uint64_t streamSeed(uint64_t seed, int global_index, int purpose) {
  return seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(global_index) * 0xD1B54A32D192ED03ull +
         static_cast<uint64_t>(purpose);
}

// The configured seed and an episode's seed in one: distinct episodes (an odd multiplier keeps
// them distinct) and distinct configured seeds give distinct streams.
uint64_t episodeSeed(int configured_seed, uint64_t episode_seed) {
  return static_cast<uint64_t>(configured_seed) ^ ((episode_seed + 1) * 0xBF58476D1CE4E5B9ull);
}

}  // namespace

std::string defaultRobotName(int index) { return "tb3_" + std::to_string(index); }

std::string robotNamespace(const std::vector<std::string>& names, int arenas, int arena, int index) {
  const std::string robot = index < static_cast<int>(names.size()) ? names[index] : defaultRobotName(index);
  return arenas > 1 ? "arena_" + std::to_string(arena) + "/" + robot : robot;
}

World::World(const map::OccupancyMap& map, const WorldConfig& config)
    : config_(validated(config)), grid_(map), scan_caster_(map), lidar_(config.robot.lidar) {
  robots_per_arena_ = static_cast<int>(config_.start_poses.size());
  for (int i = 0; i < robots_per_arena_; ++i) {
    const std::string problem = placementProblem(config_.start_poses[i], config_.start_poses, i);
    if (!problem.empty()) {
      throw nav::ParamError("start_poses[" + std::to_string(i) + "]",
                       problem + (map.yaml_path.empty() ? "" : " of " + map.yaml_path));
    }
  }
  robots_.resize(static_cast<size_t>(config_.arenas) * robots_per_arena_);
  for (size_t g = 0; g < robots_.size(); ++g) {
    Robot& robot = robots_[g];
    robot.start_pose = config_.start_poses[g % robots_per_arena_];
    seedStreams(static_cast<int>(g), static_cast<uint64_t>(config_.seed));
    resetRobot(robot);
  }
  if (config_.scan_rate > 0.0) takeScans();
}

std::string World::placementProblem(const Pose2D& pose, const std::vector<Pose2D>& arena_poses,
                                    int skip_index) const {
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw)) {
    return "pose " + formatPose(pose) + " is not finite";
  }
  const double radius = config_.robot.radius;
  if (grid_.clearance(pose.x, pose.y, radius) < radius) {
    return "robot at " + formatPose(pose) + " overlaps an obstacle";
  }
  if (!grid_.isKnownFree(pose.x, pose.y)) {
    return "robot at " + formatPose(pose) + " is not on a known free cell";
  }
  for (size_t j = 0; j < arena_poses.size(); ++j) {
    if (static_cast<int>(j) == skip_index) continue;
    if (std::hypot(arena_poses[j].x - pose.x, arena_poses[j].y - pose.y) < 2.0 * radius) {
      return "robot at " + formatPose(pose) + " overlaps robot " + std::to_string(j) + " at " +
             formatPose(arena_poses[j]);
    }
  }
  return "";
}

bool World::setCommand(int global_index, const Twist2D& command) {
  if (!std::isfinite(command.linear) || !std::isfinite(command.angular)) return false;
  Robot& robot = robots_.at(global_index);
  uint64_t apply_tick = tick_;
  if (config_.noise.command_latency_max > 0.0) {
    const double latency =
        robot.motion_rng.uniform(config_.noise.command_latency_min, config_.noise.command_latency_max);
    apply_tick += static_cast<uint64_t>(std::ceil(latency * config_.physics_rate - 1e-9));
  }
  // Latency never reorders commands.
  if (!robot.pending.empty()) apply_tick = std::max(apply_tick, robot.pending.back().apply_tick);
  robot.pending.push_back({apply_tick, command});
  return true;
}

bool World::due(uint64_t tick, double rate, double physics_rate) {
  if (rate <= 0.0) return false;
  if (tick == 0) return true;
  // Ticks at which the count of periods elapsed goes up (exact for rates dividing physics_rate).
  const double per_tick = rate / physics_rate;
  return std::floor(tick * per_tick + 1e-9) != std::floor((tick - 1) * per_tick + 1e-9);
}

const StepReport& World::step() {
  report_.collisions.clear();
  for (int g = 0; g < robotCount(); ++g) {
    updateTarget(robots_[g]);
    moveRobot(g);
  }
  for (int g = 0; g < robotCount(); ++g) releaseContacts(g);
  ++tick_;
  report_.odom_due = due(tick_, config_.odom_rate, config_.physics_rate);
  report_.scan_updated = due(tick_, config_.scan_rate, config_.physics_rate);
  if (report_.scan_updated) takeScans();
  return report_;
}

void World::updateTarget(Robot& robot) {
  while (!robot.pending.empty() && robot.pending.front().apply_tick <= tick_) {
    robot.target = limitVelocity(robot.pending.front().command, config_.robot.limits);
    robot.last_command_tick = robot.pending.front().apply_tick;
    robot.pending.pop_front();
  }
  if (config_.cmd_vel_timeout > 0.0 &&
      (tick_ - robot.last_command_tick) / config_.physics_rate >= config_.cmd_vel_timeout - 1e-12) {
    robot.target = Twist2D{};  // watchdog: the controller went quiet
  }
  const NoiseModel& noise = config_.noise;
  const bool driving = robot.target.linear != 0.0 || robot.target.angular != 0.0;
  if (noise.pause_rate > 0.0 && driving && tick_ >= robot.paused_until_tick &&
      robot.motion_rng.uniform() < noise.pause_rate / config_.physics_rate) {
    const double duration = robot.motion_rng.uniform(noise.pause_duration_min, noise.pause_duration_max);
    robot.paused_until_tick = tick_ + static_cast<uint64_t>(std::llround(duration * config_.physics_rate));
  }
}

void World::moveRobot(int global_index) {
  Robot& robot = robots_[global_index];
  const double dt = timeStep();
  const Twist2D target = tick_ < robot.paused_until_tick ? Twist2D{} : robot.target;
  robot.drive = accelerate(robot.drive, target, config_.robot.limits, dt);
  Twist2D actual = robot.drive;
  actual.linear *= config_.noise.linear_speed_scale;
  robot.state.velocity = actual;

  Pose2D& pose = robot.state.pose;
  if (actual.linear == 0.0) {  // turning on the spot never changes the footprint
    pose = integrate(pose, actual, dt);
    integrateOdometry(robot, actual, dt);
    return;
  }
  const Pose2D candidate = integrate(pose, actual, dt);
  int party = blockingParty(global_index, candidate);
  if (party == kNobody) {
    pose = candidate;
    integrateOdometry(robot, actual, dt);
    return;
  }
  // Find where along the step the contact starts, stop there, and report it. A robot
  // pushing against what it already touches is blocked at once: one test, no bisection.
  double free_fraction = 0.0, blocked_fraction = 1.0;
  const double first_fraction = std::ldexp(1.0, -kContactBisections);
  const int touching = blockingParty(global_index, integrate(pose, actual, dt * first_fraction));
  if (touching != kNobody) {
    party = touching;
    blocked_fraction = 0.0;
  }
  for (int i = 0; i < kContactBisections && blocked_fraction > 0.0; ++i) {
    const double middle = 0.5 * (free_fraction + blocked_fraction);
    const int blocker = blockingParty(global_index, integrate(pose, actual, dt * middle));
    if (blocker == kNobody) {
      free_fraction = middle;
    } else {
      blocked_fraction = middle;
      party = blocker;
    }
  }
  pose = integrate(pose, actual, dt * free_fraction);
  integrateOdometry(robot, actual, dt * free_fraction);
  // The translation stops; turning on the spot stays possible (it is how a robot gets free).
  const Twist2D turn_only{0.0, actual.angular};
  pose = integrate(pose, turn_only, dt * (1.0 - free_fraction));
  integrateOdometry(robot, turn_only, dt * (1.0 - free_fraction));
  robot.drive.linear = 0.0;
  robot.state.velocity.linear = 0.0;
  addContact(global_index, party, pose);
}

int World::blockingParty(int global_index, const Pose2D& pose) const {
  const double radius = config_.robot.radius;
  if (grid_.clearance(pose.x, pose.y, radius) < radius) return CollisionEvent::kWall;
  const int arena = global_index / robots_per_arena_;
  const double min_distance_sq = 4.0 * radius * radius;
  for (int i = 0; i < robots_per_arena_; ++i) {
    const int other = globalIndex(arena, i);
    if (other == global_index) continue;
    const Pose2D& other_pose = robots_[other].state.pose;
    const double dx = other_pose.x - pose.x, dy = other_pose.y - pose.y;
    if (dx * dx + dy * dy < min_distance_sq) return i;
  }
  return kNobody;
}

void World::addContact(int global_index, int party, const Pose2D& pose) {
  Robot& robot = robots_[global_index];
  const int arena = global_index / robots_per_arena_;
  const int index = global_index % robots_per_arena_;
  const double radius = config_.robot.radius;
  CollisionEvent event;
  event.tick = tick_ + 1;  // observed at the end of this step
  event.time = event.tick / config_.physics_rate;
  event.arena = arena;
  if (party == CollisionEvent::kWall) {
    if (robot.wall_contact) return;
    robot.wall_contact = true;
    event.robot = index;
    event.other_robot = CollisionEvent::kWall;
    event.contact = {pose.x, pose.y};
    grid_.clearance(pose.x, pose.y, radius + kContactReleaseGap, &event.contact);
    report_.collisions.push_back(event);
    return;
  }
  // A robot-robot contact is an event for each of the two robots.
  Robot& other = robots_[globalIndex(arena, party)];
  const Pose2D& other_pose = other.state.pose;
  const double distance = std::max(std::hypot(other_pose.x - pose.x, other_pose.y - pose.y), 1e-12);
  event.contact = {pose.x + (other_pose.x - pose.x) * radius / distance,
                   pose.y + (other_pose.y - pose.y) * radius / distance};
  // Each robot records the contact once (until it is released), as an event of its own.
  auto record = [&](Robot& self, int self_index, int other_index) {
    auto& contacts = self.robot_contacts;
    if (std::find(contacts.begin(), contacts.end(), other_index) != contacts.end()) return;
    contacts.push_back(other_index);
    event.robot = self_index;
    event.other_robot = other_index;
    report_.collisions.push_back(event);
  };
  record(robot, index, party);
  record(other, party, index);
}

void World::releaseContacts(int global_index) {
  Robot& robot = robots_[global_index];
  const Pose2D& pose = robot.state.pose;
  const double radius = config_.robot.radius;
  if (robot.wall_contact && grid_.clearance(pose.x, pose.y, radius + kContactReleaseGap) >= radius + kContactReleaseGap) {
    robot.wall_contact = false;
  }
  const int arena = global_index / robots_per_arena_;
  auto apart = [&](int party) {
    const Pose2D& other = robots_[globalIndex(arena, party)].state.pose;
    return std::hypot(other.x - pose.x, other.y - pose.y) >= 2.0 * radius + kContactReleaseGap;
  };
  auto& contacts = robot.robot_contacts;
  contacts.erase(std::remove_if(contacts.begin(), contacts.end(), apart), contacts.end());
}

void World::integrateOdometry(Robot& robot, const Twist2D& velocity, double dt) {
  double distance = velocity.linear * dt;
  double rotation = velocity.angular * dt;
  const NoiseModel& noise = config_.noise;
  if (noise.odom_translation_stddev > 0.0 && distance != 0.0) {
    distance *= 1.0 + noise.odom_translation_stddev * robot.motion_rng.normal();
  }
  if (noise.odom_rotation_stddev > 0.0 && (distance != 0.0 || rotation != 0.0)) {
    // Heading error grows with rotation and with distance (1 rad per m as the unit of scale).
    rotation += noise.odom_rotation_stddev * (std::abs(rotation) + std::abs(distance)) * robot.motion_rng.normal();
  }
  // The step's motion as a unit-time twist (dt may be 0 when a contact stops the robot at once).
  robot.state.odom_pose = integrate(robot.state.odom_pose, Twist2D{distance, rotation}, 1.0);
}

void World::takeScans() {
  const NoiseModel& noise = config_.noise;
  for (int arena = 0; arena < config_.arenas; ++arena) {
    for (int i = 0; i < robots_per_arena_; ++i) {
      circles_.clear();
      for (int j = 0; j < robots_per_arena_; ++j) {
        if (j == i) continue;
        const Pose2D& other = robots_[globalIndex(arena, j)].state.pose;
        circles_.push_back({other.x, other.y, config_.robot.radius});
      }
      Robot& robot = robots_[globalIndex(arena, i)];
      lidar_.castExact(scan_caster_, robot.state.pose, circles_, robot.state.scan);
      const double dropout = noise.lidar_dropout_max > 0.0
                                 ? robot.lidar_rng.uniform(noise.lidar_dropout_min, noise.lidar_dropout_max)
                                 : 0.0;
      lidar_.applyNoiseAndEncode(robot.state.scan, noise.lidar_range_stddev, dropout, robot.lidar_rng);
      robot.state.scan_tick = tick_;
    }
  }
}

void World::seedStreams(int global_index, uint64_t seed) {
  Robot& robot = robots_.at(global_index);
  robot.motion_rng.reseed(streamSeed(seed, global_index, 1));
  robot.lidar_rng.reseed(streamSeed(seed, global_index, 2));
}

void World::resetRobot(Robot& robot) {
  robot.state.pose = robot.start_pose;
  robot.state.velocity = Twist2D{};
  robot.drive = Twist2D{};
  robot.state.odom_pose = Pose2D{};
  robot.target = Twist2D{};
  robot.last_command_tick = tick_;
  robot.pending.clear();
  robot.paused_until_tick = 0;
  robot.wall_contact = false;
  robot.robot_contacts.clear();
}

std::string World::reset(int arena, const std::vector<std::pair<int, Pose2D>>& new_start_poses,
                         std::optional<uint64_t> episode_seed) {
  if (arena < -1 || arena >= config_.arenas) {
    return "arena " + std::to_string(arena) + " does not exist (arenas: " + std::to_string(config_.arenas) + ")";
  }
  std::vector<Pose2D> start_poses(robots_.size());
  for (size_t g = 0; g < robots_.size(); ++g) start_poses[g] = robots_[g].start_pose;
  for (const auto& entry : new_start_poses) {
    const int g = entry.first;
    if (g < 0 || g >= robotCount()) return "robot " + std::to_string(g) + " does not exist";
    if (arena != -1 && g / robots_per_arena_ != arena) {
      return robotNamespace(config_.robot_names, config_.arenas, g / robots_per_arena_, g % robots_per_arena_) +
             " is not in arena " + std::to_string(arena);
    }
    start_poses[g] = entry.second;
  }
  const int first_arena = arena == -1 ? 0 : arena;
  const int last_arena = arena == -1 ? config_.arenas - 1 : arena;
  for (int k = first_arena; k <= last_arena; ++k) {
    const std::vector<Pose2D> arena_poses(start_poses.begin() + globalIndex(k, 0),
                                          start_poses.begin() + globalIndex(k + 1, 0));
    for (int i = 0; i < robots_per_arena_; ++i) {
      const std::string problem = placementProblem(arena_poses[i], arena_poses, i);
      if (!problem.empty()) return robotNamespace(config_.robot_names, config_.arenas, k, i) + ": " + problem;
    }
  }
  for (int k = first_arena; k <= last_arena; ++k) {
    for (int i = 0; i < robots_per_arena_; ++i) {
      Robot& robot = robots_[globalIndex(k, i)];
      robot.start_pose = start_poses[globalIndex(k, i)];
      resetRobot(robot);
      if (episode_seed) seedStreams(globalIndex(k, i), episodeSeed(config_.seed, *episode_seed));
    }
  }
  return "";
}

}  // namespace sim
}  // namespace marl_mrta
