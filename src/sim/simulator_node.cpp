// The `simulator` node: see docs/simulator.md.
#include <ros/ros.h>

#include "marl_mrta/sim/simulator_ros.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator");
  ros::NodeHandle nh, private_nh("~");
  try {
    marl_mrta::sim::SimulatorRos simulator(nh, private_nh);
    return simulator.run();
  } catch (const std::exception& e) {  // a bad parameter, map or start pose: one line, exit 1
    ROS_FATAL("%s", e.what());
    return 1;
  }
}
