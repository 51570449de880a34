#include "move_base_ros.h"

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Path.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>
#include <fstream>

#include "marl_mrta/nav/static_layer.h"
#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace nav {

namespace conv = ros_conversions;

MoveBaseRos::MoveBaseRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), tf_source_(std::make_unique<TransformSource>()), tf_buffer_(tf_source_->buffer()),
      action_server_(nh, "move_base", false) {
  log_name_ = private_nh_.getNamespace().substr(1);
  const ParamNode ns(conv::parameterTree(private_nh_), log_name_);
  const MoveBaseConfig config = readMoveBaseConfig(ns);
  // The project's own parameters: lock-step with the simulator, statistics.
  std::string robot = nh_.getNamespace();  // the node's or the nodelet's namespace
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
  for (const std::string& key : ns.unreadKeys()) ROS_WARN("%s: unknown parameter %s (ignored)", log_name_.c_str(), key.c_str());
  for (const std::string& renamed : config.renamed_parameters_used) {
    ROS_INFO("%s: read the old parameter name %s", log_name_.c_str(), renamed.c_str());
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
        scan_inputs_[i].topic, 10, [this, i](const sensor_msgs::LaserScan::ConstPtr& msg) { onScan(i, msg); },
        ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
  const auto static_layers = core_->globalCostmap().layersOfType<StaticLayer>();
  if (!static_layers.empty()) map_sub_ = nh_.subscribe(static_layers.front()->config().map_topic, 1, &MoveBaseRos::onMap, this);

  cmd_vel_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 1);
  current_goal_pub_ = private_nh_.advertise<geometry_msgs::PoseStamped>("current_goal", 0);
  plan_pub_ = private_nh_.advertise<nav_msgs::Path>("NavfnROS/plan", 1);
  local_plan_pub_ = private_nh_.advertise<nav_msgs::Path>("DWAPlannerROS/local_plan", 1);
  global_plan_pub_ = private_nh_.advertise<nav_msgs::Path>("DWAPlannerROS/global_plan", 1);
  trajectory_cloud_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("DWAPlannerROS/trajectory_cloud", 1);
  cost_cloud_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("DWAPlannerROS/cost_cloud", 1);
  global_costmap_pub_ = private_nh_.advertise<nav_msgs::OccupancyGrid>("global_costmap/costmap", 1);
  local_costmap_pub_ = private_nh_.advertise<nav_msgs::OccupancyGrid>("local_costmap/costmap", 1);
  action_goal_pub_ = nh_.advertise<move_base_msgs::MoveBaseActionGoal>("move_base/goal", 1);
  simple_goal_sub_ = nh_.subscribe("move_base_simple/goal", 1, &MoveBaseRos::onSimpleGoal, this);
  // No Nagle delay on what a lock-step control step waits for.
  odom_sub_ = nh_.subscribe(config.dwa_odom_topic, 10, &MoveBaseRos::onOdom, this, ros::TransportHints().tcpNoDelay());
  make_plan_srv_ = private_nh_.advertiseService("make_plan", &MoveBaseRos::onMakePlan, this);
  clear_costmaps_srv_ = private_nh_.advertiseService("clear_costmaps", &MoveBaseRos::onClearCostmaps, this);
  action_server_.registerGoalCallback([this] { onGoal(); });
  action_server_.registerPreemptCallback([this] { onPreempt(); });
  action_server_.start();
  if (lockstep_) {
    ack_.robot = robot_name_;
    ack_pub_ = nh_.advertise<marl_mrta::LockstepAck>(ack_topic, 100);
    tick_sub_ = nh_.subscribe(tick_topic, 100, &MoveBaseRos::onTick, this, ros::TransportHints().tcpNoDelay());
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
    ROS_ERROR("%s: %s", log_name_.c_str(), problem.c_str());
    core_->cancel();
    publishCommand({});
    endGoal();
    action_server_.setAborted(move_base_msgs::MoveBaseResult(),
                              "Aborting on goal because it was sent with an invalid quaternion");
    return;
  }
  geometry_msgs::PoseStamped global;
  try {
    geometry_msgs::PoseStamped latest = target;
    latest.header.stamp = ros::Time(0);  // the goal's place, with the latest transform
    tf_source_->drain();
    global = tf_buffer_.transform(latest, global_frame_);
  } catch (const tf2::TransformException& error) {
    const std::string message = "Aborting on goal because it was sent in frame '" + target.header.frame_id +
                                "', which cannot be transformed into '" + global_frame_ + "': " + error.what();
    ROS_ERROR("%s: %s", log_name_.c_str(), message.c_str());
    core_->cancel();
    publishCommand({});
    endGoal();
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
  endGoal();
  action_server_.setPreempted();
}

void MoveBaseRos::onSimpleGoal(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  move_base_msgs::MoveBaseActionGoal action_goal;
  action_goal.header.stamp = ros::Time::now();
  action_goal.goal.target_pose = *msg;
  action_goal_pub_.publish(action_goal);
}

void MoveBaseRos::onMap(const nav_msgs::OccupancyGrid::ConstPtr& msg) {
  const map::OccupancyMap occupancy = conv::toOccupancyMap(*msg);
  for (LayeredCostmap* costmap : {&core_->globalCostmap(), &core_->localCostmap()}) {
    for (StaticLayer* layer : costmap->layersOfType<StaticLayer>()) layer->setMap(occupancy);
  }
  ROS_INFO("%s: map %u x %u at %.3f m", log_name_.c_str(), msg->info.width, msg->info.height, msg->info.resolution);
  if (occupancy.origin_yaw != 0.0) {  // stock costmap_2d ignores it silently; the map's obstacles then sit elsewhere
    ROS_WARN("%s: the map's origin yaw %.4f rad is ignored, as stock costmap_2d ignores it: the costmaps place the "
             "grid unrotated; rotate the map image and give a yaw of 0",
             log_name_.c_str(), occupancy.origin_yaw);
  }
}

bool MoveBaseRos::onMakePlan(nav_msgs::GetPlan::Request& req, nav_msgs::GetPlan::Response& res) {
  if (action_server_.isActive()) {
    ROS_ERROR("%s must be in an inactive state to make a plan for an external user", log_name_.c_str());
    return false;
  }
  Pose2D start, goal;
  std::string error;
  tf_source_->drain();
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
    ROS_ERROR("%s: make_plan: %s", log_name_.c_str(), ex.what());
    return false;
  }
  const PlanResult plan = core_->makePlan(start, goal, req.tolerance);
  if (!plan.ok()) ROS_WARN("%s: make_plan: %s", log_name_.c_str(), plan.message.c_str());
  res.plan = conv::toPath(plan.path, global_frame_, ros::Time::now());
  return true;
}

bool MoveBaseRos::onClearCostmaps(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  core_->clearCostmaps();
  return true;
}

void MoveBaseRos::warnThrottled(const std::string& key, double period, const std::string& text) const {
  const ros::WallTime now = ros::WallTime::now();
  const auto last = last_warned_.find(key);
  if (last != last_warned_.end() && (now - last->second).toSec() < period) return;
  last_warned_[key] = now;
  ROS_WARN("%s: %s", log_name_.c_str(), text.c_str());
}

void MoveBaseRos::writeStats() const {
  if (stats_file_.empty()) return;
  const MoveBaseTimings& t = core_->timings();
  std::ofstream out(stats_file_);
  out << "{\"robot\": \"" << robot_name_ << "\", \"plans\": " << t.plans << ", \"planning_s\": " << t.planning
      << ", \"control_cycles\": " << t.control_cycles << ", \"control_s\": " << t.control
      << ", \"global_costmap_updates\": " << t.global_updates << ", \"global_costmap_s\": " << t.global_costmap
      << ", \"local_costmap_updates\": " << t.local_updates << ", \"local_costmap_s\": " << t.local_costmap
      << ", \"cmd_vel\": " << cmd_vel_count_ << ", \"input_waits\": " << input_waits_
      << ", \"input_wait_s\": " << input_wait_seconds_ << "}\n";
}

}  // namespace nav
}  // namespace marl_mrta
