// The `simulator` as a nodelet (marl_mrta/Simulator): the same SimulatorRos as the node, on its
// own thread and callback queue, so that controllers loaded into the same manager exchange
// ticks, commands, odometry and scans without sockets (sim.launch nodelets:=true).
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>
#include <thread>

#include "marl_mrta/own_queue_nodelet.h"
#include "marl_mrta/sim/simulator_ros.h"

namespace marl_mrta {
namespace sim {

class SimulatorNodelet : public OwnQueueNodelet {
 public:
  ~SimulatorNodelet() override {
    if (simulator_) simulator_->requestStop();
    if (loop_.joinable()) loop_.join();
  }

 private:
  void onInit() override {
    ros::NodeHandle nh = publicHandle(), private_nh = privateHandle();
    try {
      simulator_ = std::make_unique<SimulatorRos>(nh, private_nh);
    } catch (const std::exception& e) {
      // The manager reports it ("Failed to initialize nodelet ..."), and `nodelet load` fails.
      NODELET_FATAL("%s", e.what());
      throw std::runtime_error(e.what());
    }
    loop_ = std::thread([this] {
      if (simulator_->run() != 0) NODELET_ERROR("simulator: the loop ended with an error");
    });
  }

  std::unique_ptr<SimulatorRos> simulator_;
  std::thread loop_;
};

}  // namespace sim
}  // namespace marl_mrta

PLUGINLIB_EXPORT_CLASS(marl_mrta::sim::SimulatorNodelet, nodelet::Nodelet)
