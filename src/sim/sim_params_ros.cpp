#include "marl_mrta/sim/sim_params_ros.h"

#include "marl_mrta/nav/ros_conversions.h"

namespace marl_mrta {
namespace sim {

SimConfig readSimConfig(const ros::NodeHandle& private_nh) {
  return readSimConfig(nav::ParamNode(nav::ros_conversions::parameterTree(private_nh), private_nh.getNamespace()));
}

}  // namespace sim
}  // namespace marl_mrta
