// The built-in map_server as a nodelet (marl_mrta/MapServer): `nodelet load marl_mrta/MapServer
// <manager> <map.yaml>`. In the simulator's manager it takes sim time from the manager instead
// of a /clock connection of its own. Its one service is served by the manager's threads.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>
#include <stdexcept>

#include "map_server_ros.h"
#include "marl_mrta/map/occupancy_map.h"

namespace marl_mrta {
namespace nav {

class MapServerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    const std::vector<std::string>& args = getMyArgv();
    if (args.empty()) {
      NODELET_FATAL("usage: nodelet load marl_mrta/MapServer <manager> <map.yaml>");
      throw std::runtime_error("map_server: no map file");
    }
    try {
      server_ = std::make_unique<MapServerRos>(getNodeHandle(), getPrivateNodeHandle(), args.front());
    } catch (const map::MapError& error) {
      NODELET_FATAL("%s", error.what());
      throw std::runtime_error(error.what());
    }
  }

  std::unique_ptr<MapServerRos> server_;
};

}  // namespace nav
}  // namespace marl_mrta

PLUGINLIB_EXPORT_CLASS(marl_mrta::nav::MapServerNodelet, nodelet::Nodelet)
