// The main() of a drop-in node whose ROS shell reads its parameters in its constructor
// (move_base, amcl): a bad parameter is one line "<node>: <problem>" and exit status 1;
// otherwise the shell runs until shutdown and exit_status(shell) is the node's status.
#pragma once

#include <ros/ros.h>

#include <memory>

#include "marl_mrta/nav/param_error.h"

namespace marl_mrta {
namespace nav {

template <class Shell, class ExitStatus>
int runNodeShell(int argc, char** argv, const char* name, ExitStatus exit_status) {
  ros::init(argc, argv, name);
  ros::NodeHandle nh, private_nh("~");
  std::unique_ptr<Shell> node;
  try {
    node = std::make_unique<Shell>(nh, private_nh);
  } catch (const ParamError& error) {
    ROS_FATAL("%s: %s", name, error.what());
    return 1;
  }
  ros::spin();
  return exit_status(*node);
}

template <class Shell>
int runNodeShell(int argc, char** argv, const char* name) {
  return runNodeShell<Shell>(argc, argv, name, [](const Shell&) { return 0; });
}

}  // namespace nav
}  // namespace marl_mrta
