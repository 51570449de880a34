#include "move_base_ros.h"

#include <geometry_msgs/Twist.h>
#include <marl_mrta/LockstepAck.h>
#include <nav_msgs/Path.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>
#include <fstream>

#include "marl_mrta/nav/static_layer.h"
#include "ros_conversions.h"

namespace marl_mrta {
namespace nav {

namespace conv = ros_conversions;

MoveBaseRos::MoveBaseRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_), action_server_(nh, "move_base", false) {
  XmlRpc::XmlRpcValue params;
  ros::param::get(private_nh_.getNamespace(), params);
  const YAML::Node tree = params.getType() == XmlRpc::XmlRpcValue::TypeStruct ? conv::toYaml(params)
                                                                              : YAML::Node(YAML::NodeType::Map);
  const ParamNode ns(tree, private_nh_.getNamespace().substr(1));
  const MoveBaseConfig config = readMoveBaseConfig(ns);
  // The project's own parameters: lock-step with the simulator, statistics.
  std::string robot = ros::this_node::getNamespace();
  robot_name_ = ns.getString("lockstep_robot", robot.substr(robot.find_first_not_of('/')));
  // Take part when the simulator runs lock-step and lists this robot (an empty list: every robot).
  std::vector<std::string> lockstep_robots;
  nh_.param("/simulator/lockstep_robots", lockstep_robots, std::vector<std::string>());
  const bool listed = lockstep_robots.empty() ||
                      std::find(lockstep_robots.begin(), lockstep_robots.end(), robot_name_) != lockstep_robots.end();
  lockstep_ = ns.getBool("lockstep", nh_.param("/simulator/lockstep", false) && listed);
  const std::string tick_topic = ns.getString("lockstep_tick_topic", "/simulator/tick");
  const std::string ack_topic = ns.getString("lockstep_ack_topic", "/simulator/lockstep_ack");
  tf_wait_ = ns.getDouble("lockstep_wait", 2.0, 0.0);
  stats_file_ = ns.getString("stats_file", "");
  for (const std::string& key : ns.unreadKeys()) ROS_WARN("move_base: unknown parameter %s (ignored)", key.c_str());
  for (const std::string& renamed : config.renamed_parameters_used) {
    ROS_INFO("move_base: read the old parameter name %s", renamed.c_str());
  }
  core_ = std::make_unique<MoveBaseCore>(config);
  global_frame_ = config.global_costmap.global_frame;
  global_base_frame_ = config.global_costmap.robot_base_frame;
  local_frame_ = config.local_costmap.global_frame;
  local_base_frame_ = config.local_costmap.robot_base_frame;
  control_period_ = 1.0 / config.controller_frequency;

  // Observation sources of both costmaps, one subscription per topic.
  for (auto [costmap, frame] : {std::make_pair(&core_->globalCostmap(), global_frame_),
                                std::make_pair(&core_->localCostmap(), local_frame_)}) {
    for (ObstacleLayer* layer : costmap->layersOfType<ObstacleLayer>()) {
      for (size_t s = 0; s < layer->config().sources.size(); ++s) {
        const ObservationSourceConfig& source = layer->config().sources[s];
        auto input = std::find_if(scan_inputs_.begin(), scan_inputs_.end(),
                                  [&](const ScanInput& in) { return in.topic == source.topic; });
        if (input == scan_inputs_.end()) input = scan_inputs_.insert(scan_inputs_.end(), ScanInput{source.topic, {}, {}});
        input->targets.push_back({costmap, layer, s, frame, source.sensor_frame});
      }
    }
  }
  for (size_t i = 0; i < scan_inputs_.size(); ++i) {
    scan_inputs_[i].sub = nh_.subscribe<sensor_msgs::LaserScan>(
        scan_inputs_[i].topic, 10, [this, i](const sensor_msgs::LaserScan::ConstPtr& msg) { onScan(i, msg); });
  }
  const auto static_layers = core_->globalCostmap().layersOfType<StaticLayer>();
  if (!static_layers.empty()) map_sub_ = nh_.subscribe(static_layers.front()->config().map_topic, 1, &MoveBaseRos::onMap, this);

  cmd_vel_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 1);
  current_goal_pub_ = private_nh_.advertise<geometry_msgs::PoseStamped>("current_goal", 0);
  plan_pub_ = private_nh_.advertise<nav_msgs::Path>("NavfnROS/plan", 1);
  local_plan_pub_ = private_nh_.advertise<nav_msgs::Path>("DWAPlannerROS/local_plan", 1);
  global_plan_pub_ = private_nh_.advertise<nav_msgs::Path>("DWAPlannerROS/global_plan", 1);
  global_costmap_pub_ = private_nh_.advertise<nav_msgs::OccupancyGrid>("global_costmap/costmap", 1);
  local_costmap_pub_ = private_nh_.advertise<nav_msgs::OccupancyGrid>("local_costmap/costmap", 1);
  action_goal_pub_ = nh_.advertise<move_base_msgs::MoveBaseActionGoal>("move_base/goal", 1);
  simple_goal_sub_ = nh_.subscribe("move_base_simple/goal", 1, &MoveBaseRos::onSimpleGoal, this);
  odom_sub_ = nh_.subscribe(config.dwa_odom_topic, 10, &MoveBaseRos::onOdom, this);
  make_plan_srv_ = private_nh_.advertiseService("make_plan", &MoveBaseRos::onMakePlan, this);
  clear_costmaps_srv_ = private_nh_.advertiseService("clear_costmaps", &MoveBaseRos::onClearCostmaps, this);
  action_server_.registerGoalCallback([this] { onGoal(); });
  action_server_.registerPreemptCallback([this] { onPreempt(); });
  action_server_.start();
  if (lockstep_) {
    ack_pub_ = nh_.advertise<marl_mrta::LockstepAck>(ack_topic, 100);
    tick_sub_ = nh_.subscribe(tick_topic, 100, &MoveBaseRos::onTick, this);
    // Re-checks ticks whose inputs are late (wall clock: sim time waits for us).
    wait_timer_ = nh_.createWallTimer(ros::WallDuration(0.05), [this](const ros::WallTimerEvent&) { processTicks(); });
  } else {
    control_timer_ = nh_.createTimer(ros::Duration(control_period_), &MoveBaseRos::onTimer, this);
  }
  ROS_INFO("move_base (built-in navfn + DWA): %s -> %s, controller %.1f Hz, planner %.1f Hz%s",
           global_frame_.c_str(), local_frame_.c_str(), config.controller_frequency, config.planner_frequency,
           lockstep_ ? (", lock-step as " + robot_name_).c_str() : "");
}

MoveBaseRos::~MoveBaseRos() { writeStats(); }

double MoveBaseRos::nowSeconds() const { return lockstep_ ? last_tick_time_.toSec() : ros::Time::now().toSec(); }

void MoveBaseRos::onGoal() {
  const auto goal = action_server_.acceptNewGoal();
  const geometry_msgs::PoseStamped& target = goal->target_pose;
  const std::string problem = conv::quaternionProblem(target.pose.orientation);
  if (!problem.empty()) {
    ROS_ERROR("move_base: %s", problem.c_str());
    core_->cancel();
    publishCommand({});
    action_server_.setAborted(move_base_msgs::MoveBaseResult(),
                              "Aborting on goal because it was sent with an invalid quaternion");
    return;
  }
  geometry_msgs::PoseStamped global;
  try {
    geometry_msgs::PoseStamped latest = target;
    latest.header.stamp = ros::Time(0);  // the goal's place, with the latest transform
    global = tf_buffer_.transform(latest, global_frame_);
  } catch (const tf2::TransformException& error) {
    const std::string message = "Aborting on goal because it was sent in frame '" + target.header.frame_id +
                                "', which cannot be transformed into '" + global_frame_ + "': " + error.what();
    ROS_ERROR("move_base: %s", message.c_str());
    core_->cancel();
    publishCommand({});
    action_server_.setAborted(move_base_msgs::MoveBaseResult(), message);
    return;
  }
  core_->setGoal(conv::toPose2D(global.pose), nowSeconds());
  current_goal_pub_.publish(global);
}

void MoveBaseRos::onPreempt() {
  if (action_server_.isNewGoalAvailable()) return;  // onGoal takes over without stopping
  if (!action_server_.isActive()) return;
  core_->cancel();
  publishCommand({});
  action_server_.setPreempted();
}

void MoveBaseRos::onSimpleGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  move_base_msgs::MoveBaseActionGoal action_goal;
  action_goal.header.stamp = ros::Time::now();
  action_goal.goal.target_pose = *msg;
  action_goal_pub_.publish(action_goal);
}

void MoveBaseRos::onOdom(const nav_msgs::Odometry::ConstPtr& msg) {
  last_odom_ = msg;
  if (lockstep_) processTicks();
}

void MoveBaseRos::onScan(size_t input, const sensor_msgs::LaserScan::ConstPtr& msg) {
  pending_scans_.emplace_back(input, msg);
  if (msg->header.stamp > last_scan_stamp_) last_scan_stamp_ = msg->header.stamp;
  if (lockstep_) processTicks();
}

void MoveBaseRos::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  const map::OccupancyMap occupancy = conv::toOccupancyMap(*msg);
  for (LayeredCostmap* costmap : {&core_->globalCostmap(), &core_->localCostmap()}) {
    for (StaticLayer* layer : costmap->layersOfType<StaticLayer>()) layer->setMap(occupancy);
  }
  ROS_INFO("move_base: map %u x %u at %.3f m", msg->info.width, msg->info.height, msg->info.resolution);
}

void MoveBaseRos::onTick(const marl_mrta::SimTick::ConstPtr& msg) {
  pending_ticks_.push_back({*msg, ros::WallTime::now()});
  processTicks();
}

void MoveBaseRos::onTimer(const ros::TimerEvent&) { controlStep(ros::Time::now(), ros::Time(0)); }

void MoveBaseRos::processTicks() {
  while (!pending_ticks_.empty()) {
    const marl_mrta::SimTick tick = pending_ticks_.front().first;
    marl_mrta::LockstepAck ack;
    ack.robot = robot_name_;
    ack.tick = tick.tick;
    if (static_cast<int64_t>(tick.tick) > last_acked_tick_) {
      // This tick's inputs travel on other connections: wait for them (bounded by wall time).
      // Control on the first tick of each controller period counted from time 0, so that the
      // phase never depends on when move_base started or a goal arrived.
      const int64_t period_index = static_cast<int64_t>(std::floor(tick.stamp.toSec() / control_period_ + 1e-6));
      const bool control = period_index != last_control_period_;
      const bool late = (ros::WallTime::now() - pending_ticks_.front().second).toSec() > tf_wait_;
      const bool odom_ready = !control || (last_odom_ && last_odom_->header.stamp >= tick.stamp);
      const bool scan_ready = !tick.scan_published || scan_inputs_.empty() || last_scan_stamp_ >= tick.stamp;
      if (!(odom_ready && scan_ready) && !late) return;
      if (late) ROS_WARN_THROTTLE(5.0, "move_base: inputs of tick %lu missing, going on", (unsigned long)tick.tick);
      last_tick_time_ = tick.stamp;
      if (control) {
        last_control_period_ = period_index;
        controlStep(tick.stamp, tick.stamp);
      }
      last_acked_tick_ = static_cast<int64_t>(tick.tick);
    }
    ack.cmd_vel_count = cmd_vel_count_;
    ack_pub_.publish(ack);
    pending_ticks_.pop_front();
  }
}

bool MoveBaseRos::lookupPose(const std::string& target, const std::string& source, const ros::Time& time,
                             Pose2D& pose, std::string& error) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(tf_wait_);
  while (!tf_buffer_.canTransform(target, source, time, &error)) {
    if (time.isZero() || ros::WallTime::now() > deadline || !ros::ok()) return false;
    ros::WallDuration(0.0002).sleep();
  }
  pose = conv::toPose2D(tf_buffer_.lookupTransform(target, source, time));
  return true;
}

void MoveBaseRos::insertScans(const ros::Time& time) {
  while (!pending_scans_.empty()) {
    const auto [input, scan] = pending_scans_.front();
    if (!time.isZero() && scan->header.stamp > time) return;  // belongs to a later tick
    const ros::Time at = lockstep_ ? scan->header.stamp : ros::Time(0);
    for (const ScanTarget& target : scan_inputs_[input].targets) {
      Pose2D sensor, origin;
      std::string error;
      if (!lookupPose(target.frame, scan->header.frame_id, at, sensor, error)) {
        ROS_WARN_THROTTLE(5.0, "move_base: scan dropped, no transform %s <- %s: %s", target.frame.c_str(),
                          scan->header.frame_id.c_str(), error.c_str());
        continue;
      }
      LaserScanData data{scan->angle_min, scan->angle_increment, scan->range_min, scan->range_max, scan->ranges,
                         scan->header.stamp.toSec()};
      const ObservationSourceConfig& source = target.layer->config().sources[target.source];
      // Height of the sensor (the planar pose leaves it out): only for the height filters.
      const double z = tf_buffer_.lookupTransform(target.frame, scan->header.frame_id, at).transform.translation.z;
      Observation observation = laserScanToObservation(data, {sensor.x, sensor.y, z, sensor.yaw}, source);
      if (!target.sensor_frame.empty() && target.sensor_frame != scan->header.frame_id &&
          lookupPose(target.frame, target.sensor_frame, at, origin, error)) {
        observation.origin = {origin.x, origin.y, z};
      }
      target.layer->addObservation(target.source, std::move(observation));
    }
    pending_scans_.pop_front();
  }
}

void MoveBaseRos::controlStep(const ros::Time& stamp, const ros::Time& lookup_time) {
  insertScans(lookup_time);
  Pose2D pose_global, pose_local;
  std::string error;
  if (!lookupPose(global_frame_, global_base_frame_, lookup_time, pose_global, error) ||
      !lookupPose(local_frame_, local_base_frame_, lookup_time, pose_local, error)) {
    ROS_WARN_THROTTLE(5.0, "move_base: robot pose unavailable: %s", error.c_str());
    if (core_->active()) publishCommand({});
    return;
  }
  const double now = stamp.toSec();
  core_->updateCostmaps(now, pose_global, pose_local);
  publishCostmaps(now, stamp);
  if (!core_->active()) return;
  Velocity2D velocity;
  if (last_odom_) velocity = {last_odom_->twist.twist.linear.x, last_odom_->twist.twist.linear.y,
                              last_odom_->twist.twist.angular.z};
  const CycleOutput out = core_->runCycle({now, pose_global, pose_local, velocity});
  publishOutputs(out, pose_global, stamp);
}

void MoveBaseRos::publishCommand(const Velocity2D& command) {
  geometry_msgs::Twist twist;
  twist.linear.x = command.x;
  twist.linear.y = command.y;
  twist.angular.z = command.theta;
  cmd_vel_pub_.publish(twist);
  ++cmd_vel_count_;
}

void MoveBaseRos::publishOutputs(const CycleOutput& out, const Pose2D& pose, const ros::Time& stamp) {
  if (out.publish_command) publishCommand(out.command);
  if (!out.recovery_started.empty()) ROS_WARN("move_base: running recovery behavior %s", out.recovery_started.c_str());
  if (out.new_plan && plan_pub_.getNumSubscribers() > 0) plan_pub_.publish(conv::toPath(out.plan, global_frame_, stamp));
  if (!out.local_plan.empty() && local_plan_pub_.getNumSubscribers() > 0) {
    local_plan_pub_.publish(conv::toPath(out.local_plan, local_frame_, stamp));
  }
  if (!action_server_.isActive()) return;
  switch (out.outcome) {
    case CycleOutput::Outcome::kSucceeded:
      ROS_INFO("move_base: %s", out.message.c_str());
      action_server_.setSucceeded(move_base_msgs::MoveBaseResult(), out.message);
      break;
    case CycleOutput::Outcome::kAborted:
      ROS_ERROR("move_base: %s", out.message.c_str());
      action_server_.setAborted(move_base_msgs::MoveBaseResult(), out.message);
      break;
    case CycleOutput::Outcome::kNone: {
      if (!out.message.empty()) ROS_WARN_THROTTLE(1.0, "move_base: %s", out.message.c_str());
      move_base_msgs::MoveBaseFeedback feedback;
      feedback.base_position.header.frame_id = global_frame_;
      feedback.base_position.header.stamp = stamp;
      feedback.base_position.pose.position.x = pose.x;
      feedback.base_position.pose.position.y = pose.y;
      feedback.base_position.pose.orientation = conv::quaternionFromYaw(pose.yaw);
      action_server_.publishFeedback(feedback);
      break;
    }
  }
}

void MoveBaseRos::publishCostmaps(double now, const ros::Time& stamp) {
  const MoveBaseConfig& config = core_->config();
  auto publish = [&](ros::Publisher& pub, LayeredCostmap& costmap, const CostmapConfig& cc, double& next) {
    if (cc.publish_frequency <= 0.0 || now < next || pub.getNumSubscribers() == 0) return;
    next = now + 1.0 / cc.publish_frequency - 1e-9;
    pub.publish(conv::costmapToOccupancyGrid(costmap.costmap(), cc.global_frame, stamp));
  };
  publish(global_costmap_pub_, core_->globalCostmap(), config.global_costmap, next_global_publish_);
  publish(local_costmap_pub_, core_->localCostmap(), config.local_costmap, next_local_publish_);
}

bool MoveBaseRos::onMakePlan(nav_msgs::GetPlan::Request& req, nav_msgs::GetPlan::Response& res) {
  if (action_server_.isActive()) {
    ROS_ERROR("move_base must be in an inactive state to make a plan for an external user");
    return false;
  }
  Pose2D start, goal;
  std::string error;
  try {
    if (req.start.header.frame_id.empty()) {
      if (!lookupPose(global_frame_, global_base_frame_, ros::Time(0), start, error)) throw tf2::TransformException(error);
    } else {
      req.start.header.stamp = ros::Time(0);
      start = conv::toPose2D(tf_buffer_.transform(req.start, global_frame_).pose);
    }
    req.goal.header.stamp = ros::Time(0);
    goal = conv::toPose2D(tf_buffer_.transform(req.goal, global_frame_).pose);
  } catch (const tf2::TransformException& ex) {
    ROS_ERROR("move_base: make_plan: %s", ex.what());
    return false;
  }
  const PlanResult plan = core_->makePlan(start, goal, req.tolerance);
  if (!plan.ok()) ROS_WARN("move_base: make_plan: %s", plan.message.c_str());
  res.plan = conv::toPath(plan.path, global_frame_, ros::Time::now());
  return true;
}

bool MoveBaseRos::onClearCostmaps(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  core_->clearCostmaps();
  return true;
}

void MoveBaseRos::writeStats() const {
  if (stats_file_.empty()) return;
  const MoveBaseTimings& t = core_->timings();
  std::ofstream out(stats_file_);
  out << "{\"robot\": \"" << robot_name_ << "\", \"plans\": " << t.plans << ", \"planning_s\": " << t.planning
      << ", \"control_cycles\": " << t.control_cycles << ", \"control_s\": " << t.control
      << ", \"global_costmap_updates\": " << t.global_updates << ", \"global_costmap_s\": " << t.global_costmap
      << ", \"local_costmap_updates\": " << t.local_updates << ", \"local_costmap_s\": " << t.local_costmap
      << ", \"cmd_vel\": " << cmd_vel_count_ << "}\n";
}

}  // namespace nav
}  // namespace marl_mrta
