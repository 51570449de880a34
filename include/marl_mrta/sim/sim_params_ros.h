// Reads the simulator's private ROS parameters into a SimConfig, through the parameter tree
// navigation reads too: each typed, every key known (a misspelt parameter is an error, not a
// silent default).
#pragma once

#include <ros/node_handle.h>

#include "marl_mrta/sim/sim_config.h"

namespace marl_mrta {
namespace sim {

// Throws nav::ParamError whose where() is the full parameter name, e.g. "/simulator/robots".
SimConfig readSimConfig(const ros::NodeHandle& private_nh);

}  // namespace sim
}  // namespace marl_mrta
