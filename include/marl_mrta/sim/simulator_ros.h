// The `simulator` node's ROS interface around one World: topics, tf, /clock, services,
// real-time pacing and the lock-step protocol (docs/design.md, docs/reference/nodes_sim_nav.md).
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include <geometry_msgs/Twist.h>
#include <marl_mrta/LockstepAck.h>
#include <marl_mrta/ResetSim.h>
#include <marl_mrta/RunSim.h>
#include <marl_mrta/SimTick.h>
#include <marl_mrta/StepSim.h>
#include <std_srvs/SetBool.h>

#include "marl_mrta/sim/lockstep_gate.h"
#include "marl_mrta/sim/sim_config.h"
#include "marl_mrta/sim/sim_messages_ros.h"
#include "marl_mrta/sim/world.h"

namespace marl_mrta {
namespace sim {

class SimulatorRos {
 public:
  // Reads and checks the parameters, loads the map, builds the world. Throws nav::ParamError
  // or map::MapError (one line each, naming the parameter or file). The loop serves
  // the callback queue of `nh` (the global one in the node, its own in the nodelet).
  SimulatorRos(ros::NodeHandle& nh, ros::NodeHandle& private_nh);

  // Runs until shutdown, requestStop() or stop_after; returns the process exit code.
  int run();
  // Ends run() at its next turn; callable from any thread (the nodelet's unload).
  void requestStop() { stop_requested_ = true; }

 private:
  struct RobotIo {
    std::string ns;
    ros::Subscriber cmd_vel_sub;
    ros::Publisher odom_pub, ground_truth_pub, scan_pub;
    RobotMessages msgs;  // frame ids filled once
  };
  // Wall time spent per part of the loop while running (not paused), for ~stats_file.
  struct Timing {
    double simulate = 0.0, publish = 0.0, paused = 0.0;
    ros::WallTime start, paused_since;
    uint64_t paused_ticks = 0;  // ticks advanced by ~step while paused
  };

  void advertise(ros::NodeHandle& nh, ros::NodeHandle& private_nh);
  void onCmdVel(size_t robot, const geometry_msgs::Twist::ConstPtr& msg);
  void onLockstepAck(const marl_mrta::LockstepAck::ConstPtr& msg);
  // Services (simulator_services_ros.cpp).
  bool onReset(marl_mrta::ResetSim::Request& req, marl_mrta::ResetSim::Response& res);
  bool onPause(std_srvs::SetBool::Request& req, std_srvs::SetBool::Response& res);
  bool onStep(marl_mrta::StepSim::Request& req, marl_mrta::StepSim::Response& res);
  bool onRunUntil(marl_mrta::RunSim::Request& req, marl_mrta::RunSim::Response& res);
  void setPaused(bool paused);
  int robotIndex(const std::string& ns) const;  // -1: no such robot

  void stepAndPublish();
  void publishState(const StepReport& report, bool initial);
  ros::Time stamp() const;  // of the current tick
  ros::Time stampOf(uint64_t tick) const;
  // First tick stamped at or after `time` (0 for time 0).
  uint64_t firstTickAtOrAfter(const ros::Time& time) const;
  // Re-sends the current tick when a lock-step answer to it is missing and none was sent for a
  // while (controllers that subscribed after it went out), and now and then while paused in
  // lock-step (observers of the answers that lost some). Returns whether it did.
  bool resendTick(const ros::WallTime& now);
  void warnLockstepWait() const;
  void writeStats() const;

  SimConfig config_;
  std::unique_ptr<World> world_;
  std::vector<RobotIo> robots_;
  ros::Publisher clock_pub_, tick_pub_, collisions_pub_, tf_pub_;
  ros::Subscriber lockstep_ack_sub_;
  ros::ServiceServer reset_srv_, pause_srv_, step_srv_, run_until_srv_;
  tf2_msgs::TFMessage tf_message_;  // every robot's transforms, refilled at each odometry tick
  marl_mrta::SimTick last_tick_;  // re-sent while lock-step answers are missing
  ros::WallTime tick_sent_;        // when a tick was last published
  std::unique_ptr<LockstepGate> lockstep_;
  std::unique_ptr<GoalEndWatch> goal_ends_;  // ~run_until's until_goals_end_of
  std::unique_ptr<RealTimePacer> pacer_;
  ros::CallbackQueue* queue_;
  std::atomic<bool> stop_requested_{false};
  bool paused_ = false;
  uint64_t run_until_tick_ = 0;  // ~run_until: pause on reaching this tick (0: no limit)
  Timing timing_;
};

}  // namespace sim
}  // namespace marl_mrta
