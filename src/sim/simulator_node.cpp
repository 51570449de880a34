// The `simulator` node: see docs/reference/nodes_sim_nav.md. With ~stand_in true it is the hardware stand-in
// (docs/guide/real_robots.md): the same world shown as TurtleBot3 Burgers on wall time.
#include <ros/ros.h>

#include "marl_mrta/sim/simulator_ros.h"
#include "marl_mrta/sim/stand_in_ros.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "simulator");
  ros::NodeHandle nh, private_nh("~");
  try {
    bool stand_in = false;
    private_nh.param("stand_in", stand_in, false);
    if (stand_in) {
      marl_mrta::sim::StandInRos burgers(nh, private_nh);
      return burgers.run();
    }
    marl_mrta::sim::SimulatorRos simulator(nh, private_nh);
    return simulator.run();
  } catch (const std::exception& e) {  // a bad parameter, map or start pose: one line, exit 1
    ROS_FATAL("%s", e.what());
    return 1;
  }
}
