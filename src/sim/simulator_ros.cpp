#include "marl_mrta/sim/simulator_ros.h"

#include <marl_mrta/CollisionEvent.h>
#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/publish_shared.h"
#include "marl_mrta/sim/sim_messages_ros.h"
#include "marl_mrta/sim/sim_params_ros.h"

namespace marl_mrta {
namespace sim {

namespace {

// While a lock-step controller is missing, the current tick is re-sent this often [wall s],
// so that controllers started after the simulator join in.
constexpr double kLockstepResendPeriod = 0.5;
// Further behind real time than this [wall s] (a loaded machine), pacing starts afresh
// rather than running flat out to catch up.
constexpr double kMaxPacingLag = 1.0;
// Waiting this long [wall s] for lock-step answers is worth a warning.
constexpr double kLockstepWarnAfter = 5.0;
// While paused in lock-step, the current tick is re-sent this often [wall s] even when every
// controller has answered it: the task manager, in another process, waits for the answers too
// and with 16 robots was seen to miss some, then wait for them in vain. Controllers answer a
// re-sent tick again, computing nothing, so the episode does not change.
constexpr double kPausedRepeatPeriod = 1.0;

}  // namespace

SimulatorRos::SimulatorRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
    : queue_(dynamic_cast<ros::CallbackQueue*>(nh.getCallbackQueue())) {
  if (!queue_) queue_ = ros::getGlobalCallbackQueue();
  config_ = readSimConfig(private_nh);
  const std::string prefix = private_nh.getNamespace() + "/";
  WorldConfig world_config;
  try {
    world_config = makeWorldConfig(config_);
  } catch (const nav::ParamError& e) {
    throw nav::ParamError(prefix + e.where(), e.problem());
  }
  const map::OccupancyMap map = map::loadMap(config_.map_file);
  try {
    world_ = std::make_unique<World>(map, world_config);
  } catch (const nav::ParamError& e) {
    throw nav::ParamError(prefix + e.where(), e.problem());
  }
  advertise(nh, private_nh);
  pacer_ = std::make_unique<RealTimePacer>(config_.physics_rate, config_.rtf, kMaxPacingLag);
  ROS_INFO("simulator: %d robot(s) in %d arena(s) on %s (%d x %d cells), physics %g Hz, scans %g Hz, rtf %g%s",
           config_.robots, config_.arenas, config_.map_file.c_str(), map.width, map.height, config_.physics_rate,
           config_.scan_rate, config_.rtf, config_.lockstep ? ", lock-step" : "");
}

void SimulatorRos::advertise(ros::NodeHandle& nh, ros::NodeHandle& private_nh) {
  const std::vector<std::string> names = robotNamespaces(config_);
  robots_.resize(names.size());
  tf_message_.transforms.resize(config_.publish_localization ? 2 * names.size() : names.size());
  for (size_t g = 0; g < names.size(); ++g) {
    RobotIo& io = robots_[g];
    io.ns = names[g];
    // Large queue: in lock-step every command must arrive (the acks count them).
    io.cmd_vel_sub = nh.subscribe<geometry_msgs::Twist>(
        io.ns + "/cmd_vel", 100,
        boost::function<void(const geometry_msgs::Twist::ConstPtr&)>(
            [this, g](const geometry_msgs::Twist::ConstPtr& msg) { onCmdVel(g, msg); }),
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    // Queues of 100: a subscriber on a busy machine may fall behind for a while at high rtf.
    io.odom_pub = nh.advertise<nav_msgs::Odometry>(io.ns + "/odom", 100);
    io.ground_truth_pub = nh.advertise<nav_msgs::Odometry>(io.ns + "/base_pose_ground_truth", 100);
    io.scan_pub = nh.advertise<sensor_msgs::LaserScan>(io.ns + "/scan", 100);
    io.msgs = robotMessages(io.ns, world_->config().robot.lidar, config_.scan_rate);
  }
  std::vector<bool> lockstep(names.size(), false);
  const auto& listed = config_.lockstep_robots;
  for (size_t g = 0; g < names.size(); ++g) {
    lockstep[g] = config_.lockstep && (listed.empty() || std::find(listed.begin(), listed.end(), names[g]) != listed.end());
  }
  lockstep_ = std::make_unique<LockstepGate>(lockstep);
  goal_ends_ = std::make_unique<GoalEndWatch>(robots_.size());
  clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);  // as tf2_ros::TransformBroadcaster
  tick_pub_ = private_nh.advertise<marl_mrta::SimTick>("tick", 100);
  collisions_pub_ = private_nh.advertise<marl_mrta::CollisionEvent>("collisions", 100);
  // No Nagle delay on what a lock-step round trip waits for.
  lockstep_ack_sub_ = private_nh.subscribe("lockstep_ack", 100, &SimulatorRos::onLockstepAck, this,
                                           ros::TransportHints().tcpNoDelay());
  reset_srv_ = private_nh.advertiseService("reset", &SimulatorRos::onReset, this);
  pause_srv_ = private_nh.advertiseService("pause", &SimulatorRos::onPause, this);
  step_srv_ = private_nh.advertiseService("step", &SimulatorRos::onStep, this);
  run_until_srv_ = private_nh.advertiseService("run_until", &SimulatorRos::onRunUntil, this);
}

void SimulatorRos::onCmdVel(size_t robot, const geometry_msgs::Twist::ConstPtr& msg) {
  lockstep_->commandReceived(static_cast<int>(robot));
  if (!world_->setCommand(static_cast<int>(robot), {msg->linear.x, msg->angular.z})) {
    ROS_WARN_THROTTLE(5.0, "%s/cmd_vel: command with a non-finite value ignored", robots_[robot].ns.c_str());
  }
}

int SimulatorRos::robotIndex(const std::string& ns) const {
  const auto found = std::find_if(robots_.begin(), robots_.end(), [&](const RobotIo& io) { return io.ns == ns; });
  return found == robots_.end() ? -1 : static_cast<int>(found - robots_.begin());
}

void SimulatorRos::onLockstepAck(const marl_mrta::LockstepAck::ConstPtr& msg) {
  const int robot = robotIndex(msg->robot);
  if (robot >= 0) goal_ends_->goalEnded(robot, msg->goal_end_tick);
  if (robot < 0 || !lockstep_->ackReceived(robot, msg->tick, msg->cmd_vel_count, firstTickAtOrAfter(msg->next_stamp),
                                           world_->tick())) {
    ROS_WARN_THROTTLE(5.0, "lockstep_ack: robot '%s' is not in ~lockstep_robots; ignored", msg->robot.c_str());
  }
}

ros::Time SimulatorRos::stamp() const { return stampOf(world_->tick()); }

ros::Time SimulatorRos::stampOf(uint64_t tick) const {
  ros::Time time;
  time.fromNSec(static_cast<uint64_t>(std::llround(tick * 1e9 / config_.physics_rate)));
  return time;
}

uint64_t SimulatorRos::firstTickAtOrAfter(const ros::Time& time) const {
  if (time.isZero()) return 0;
  // Estimate, then settle on the exact stamps (rounded to nanoseconds as stampOf).
  uint64_t tick = static_cast<uint64_t>(std::max(0.0, std::floor(time.toSec() * config_.physics_rate)));
  while (stampOf(tick) < time) ++tick;
  while (tick > 0 && stampOf(tick - 1) >= time) --tick;
  return tick;
}

void SimulatorRos::stepAndPublish() {
  const ros::WallTime start = ros::WallTime::now();
  const StepReport& report = world_->step();
  const ros::WallTime simulated = ros::WallTime::now();
  publishState(report, false);
  timing_.simulate += (simulated - start).toSec();
  tick_sent_ = ros::WallTime::now();
  timing_.publish += (tick_sent_ - simulated).toSec();
}

void SimulatorRos::publishState(const StepReport& report, bool initial) {
  const ros::Time now = stamp();
  rosgraph_msgs::Clock clock;
  clock.clock = now;
  publishShared(clock_pub_, clock);
  for (const CollisionEvent& event : report.collisions) {
    marl_mrta::CollisionEvent msg;
    msg.stamp = now;
    msg.arena = event.arena;
    msg.robot = robots_[world_->globalIndex(event.arena, event.robot)].ns;
    msg.other = event.other_robot == CollisionEvent::kWall
                    ? "wall" : robots_[world_->globalIndex(event.arena, event.other_robot)].ns;
    msg.position.x = event.contact.x;
    msg.position.y = event.contact.y;
    collisions_pub_.publish(msg);
  }
  if (initial || report.odom_due) {
    for (size_t g = 0; g < robots_.size(); ++g) {
      RobotIo& io = robots_[g];
      const RobotState& state = world_->robot(static_cast<int>(g));
      fillOdometry(io.msgs.odom, now, state.odom_pose, state.velocity);
      fillOdometry(io.msgs.ground_truth, now, state.pose, state.velocity);
      publishShared(io.odom_pub, io.msgs.odom);
      publishShared(io.ground_truth_pub, io.msgs.ground_truth);
      fillTransform(io.msgs.odom_tf, now, state.odom_pose);
      // Every map -> odom before any odom -> base_footprint: a tf listener inserts a message's
      // transforms one at a time, and stock costmap_2d and DWA look up odom -> base at its latest
      // stamp, then map -> odom at that stamp; between two inserts the second must not be missing.
      const size_t odom_index = config_.publish_localization ? robots_.size() + g : g;
      tf_message_.transforms[odom_index] = io.msgs.odom_tf;
      if (config_.publish_localization) {
        fillLocalization(io.msgs);
        tf_message_.transforms[g] = io.msgs.map_odom_tf;
      }
    }
    publishShared(tf_pub_, tf_message_);  // one message for every robot
  }
  const bool scans = config_.scan_rate > 0.0 && (initial || report.scan_updated);
  if (scans) {
    for (size_t g = 0; g < robots_.size(); ++g) {
      RobotIo& io = robots_[g];
      io.msgs.scan.header.stamp = now;
      io.msgs.scan.ranges = world_->robot(static_cast<int>(g)).scan;
      publishShared(io.scan_pub, io.msgs.scan);
    }
  }
  last_tick_.tick = world_->tick();
  last_tick_.stamp = now;
  last_tick_.scan_published = scans;
  if (scans) last_tick_.last_scan_stamp = now;
  publishShared(tick_pub_, last_tick_);
}

bool SimulatorRos::resendTick(const ros::WallTime& now) {
  const double period = !lockstep_->answered(world_->tick())  ? kLockstepResendPeriod
                        : paused_ && config_.lockstep          ? kPausedRepeatPeriod
                                                               : -1.0;
  if (period < 0.0 || (now - tick_sent_).toSec() <= period) return false;
  publishShared(tick_pub_, last_tick_);
  tick_sent_ = now;
  return true;
}

int SimulatorRos::run() {
  ros::CallbackQueue& queue = *queue_;
  timing_.start = timing_.paused_since = ros::WallTime::now();
  paused_ = config_.start_paused;
  publishState(StepReport{}, true);
  tick_sent_ = timing_.start;
  ros::WallTime tick_stepped = timing_.start;
  while (ros::ok() && !stop_requested_) {
    queue.callAvailable();
    if (goal_ends_->active() && goal_ends_->pauseTick() > 0) {
      // The ack of the tick on which the last watched goal ended came before this tick's step.
      const uint64_t tick = goal_ends_->pauseTick();
      run_until_tick_ = run_until_tick_ > 0 ? std::min(run_until_tick_, tick) : tick;
      goal_ends_->clear();
    }
    if (config_.stop_after > 0.0 && world_->time() >= config_.stop_after - 1e-9) break;
    if (!paused_ && run_until_tick_ > 0 && world_->tick() >= run_until_tick_) {
      setPaused(true);  // on ~run_until's tick, before any later one
      run_until_tick_ = 0;
      goal_ends_->clear();
    }
    const ros::WallTime now = ros::WallTime::now();
    if (paused_) {
      resendTick(now);  // a controller that joined while paused answers the current tick
      queue.callAvailable(ros::WallDuration(0.05));
      continue;
    }
    if (!lockstep_->answered(world_->tick())) {
      if (resendTick(now) && (now - tick_stepped).toSec() > kLockstepWarnAfter) warnLockstepWait();
      queue.callAvailable(ros::WallDuration(0.01));  // returns as soon as an answer arrives
      pacer_->restart();
      continue;
    }
    const double wait = pacer_->waitBeforeStep(now.toSec(), world_->tick());
    if (wait > 0.0) {
      queue.callAvailable(ros::WallDuration(wait));  // sleeps, but serves callbacks meanwhile
      continue;
    }
    stepAndPublish();
    tick_stepped = now;
  }
  writeStats();
  return 0;
}

void SimulatorRos::warnLockstepWait() const {
  std::string missing;
  for (int g : lockstep_->missing(world_->tick())) missing += (missing.empty() ? "" : ", ") + robots_[g].ns;
  ROS_WARN_THROTTLE(5.0, "waiting for lock-step answers for tick %lu from: %s",
                    static_cast<unsigned long>(world_->tick()), missing.c_str());
}

void SimulatorRos::writeStats() const {
  if (config_.stats_file.empty()) return;
  // Only the time spent running counts (a benchmark starts paused while subscribers connect).
  const ros::WallTime now = ros::WallTime::now();
  const double wall = (now - timing_.start).toSec() - timing_.paused - (paused_ ? (now - timing_.paused_since).toSec() : 0.0);
  const double sim = (world_->tick() - timing_.paused_ticks) / config_.physics_rate;
  std::ofstream out(config_.stats_file);
  out << "{\"robots\": " << robots_.size() << ", \"ticks\": " << world_->tick() << ", \"sim_seconds\": " << sim
      << ", \"wall_seconds\": " << wall << ", \"rtf\": " << sim / wall << ", \"simulate_seconds\": " << timing_.simulate
      << ", \"publish_seconds\": " << timing_.publish << "}\n";
  if (!out) ROS_ERROR("%s: stats_file: cannot write", config_.stats_file.c_str());
}

}  // namespace sim
}  // namespace marl_mrta
