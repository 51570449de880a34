// The simulator's services: reset, pause, step and run_until (simulator_ros.h).
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "marl_mrta/sim/simulator_ros.h"

namespace marl_mrta {
namespace sim {

bool SimulatorRos::onReset(marl_mrta::ResetSim::Request& req, marl_mrta::ResetSim::Response& res) {
  std::vector<std::pair<int, Pose2D>> poses;
  if (req.robots.size() != req.poses.size()) {
    res.message = "robots and poses differ in length (" + std::to_string(req.robots.size()) + " vs " +
                  std::to_string(req.poses.size()) + ")";
  }
  for (size_t i = 0; i < req.robots.size() && res.message.empty(); ++i) {
    const int robot = robotIndex(req.robots[i]);
    if (robot < 0) res.message = "unknown robot '" + req.robots[i] + "'";
    else poses.push_back({robot, {req.poses[i].x, req.poses[i].y, req.poses[i].theta}});
  }
  if (res.message.empty() && req.reseed && req.seed < 0) res.message = "seed must be >= 0, got " + std::to_string(req.seed);
  std::optional<uint64_t> episode_seed;
  if (req.reseed) episode_seed = static_cast<uint64_t>(req.seed);
  if (res.message.empty()) res.message = world_->reset(req.arena, poses, episode_seed);
  res.success = res.message.empty();
  if (res.success) res.message = "reset at tick " + std::to_string(world_->tick());
  return true;
}

void SimulatorRos::setPaused(bool paused) {
  const ros::WallTime now = ros::WallTime::now();
  if (paused && !paused_) timing_.paused_since = now;
  if (!paused && paused_) timing_.paused += (now - timing_.paused_since).toSec();
  paused_ = paused;
  pacer_->restart();
}

bool SimulatorRos::onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res) {
  setPaused(req.data);
  run_until_tick_ = 0;
  goal_ends_->clear();
  res.success = true;
  res.message = (paused_ ? "paused at tick " : "running from tick ") + std::to_string(world_->tick());
  return true;
}

bool SimulatorRos::onStep(marl_mrta::StepSim::Request& req, marl_mrta::StepSim::Response& res) {
  for (uint32_t i = 0; i < req.ticks; ++i) stepAndPublish();
  if (paused_) timing_.paused_ticks += req.ticks;
  pacer_->restart();
  res.tick = world_->tick();
  res.stamp = stamp();
  return true;
}

bool SimulatorRos::onRunUntil(marl_mrta::RunSim::Request& req, marl_mrta::RunSim::Response& res) {
  std::vector<int> watched;
  for (const std::string& ns : req.until_goals_end_of) {
    const int robot = robotIndex(ns);
    if (robot < 0) {
      ROS_ERROR("run_until: until_goals_end_of: no robot '%s'", ns.c_str());
      return false;
    }
    watched.push_back(robot);
  }
  goal_ends_->start(std::move(watched), world_->tick(), req.align_ticks, req.until_first_goal_end);
  run_until_tick_ = req.until_tick;
  setPaused(req.until_tick <= world_->tick());
  res.tick = world_->tick();
  res.stamp = stamp();
  return true;
}

}  // namespace sim
}  // namespace marl_mrta
