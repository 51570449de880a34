#include "marl_mrta/nav/travel_c_api.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "marl_mrta/map/occupancy_map.h"
#include "marl_mrta/nav/move_base_core.h"
#include "marl_mrta/nav/static_layer.h"

// The paths of every ordered pair (a, b), a != b, as x, y, x, y, ...
struct MarlMrtaTravel {
  int n = 0;
  std::vector<std::vector<double>> xy;  // [a * n + b]
  double max_speed = 0.0;               // [m/s] the fastest DWA drives: min(max_vel_x, max_vel_trans)
};

namespace marl_mrta {
namespace nav {
namespace {

// A pose that cannot be planned from or to; what() is the one line to report.
class PoseProblem : public std::runtime_error {
 public:
  PoseProblem(int pose, const std::string& message) : std::runtime_error(message), pose_(pose) {}
  int pose() const { return pose_; }

 private:
  int pose_;
};

std::string describePose(int index, const Pose2D& pose) {
  std::ostringstream out;
  out.precision(2);
  out << std::fixed << "pose " << index << " (" << pose.x << ", " << pose.y << ")";
  return out.str();
}

// The map as move_base receives it from map_server: nav_msgs/MapMetaData carries the resolution
// as a float32, and the costmap's cells and the path's points follow it.
map::OccupancyMap asPublished(map::OccupancyMap occupancy) {
  occupancy.resolution = static_cast<float>(occupancy.resolution);
  return occupancy;
}

void checkPoses(const CostGrid& costs, const std::vector<Pose2D>& poses, const std::string& map_yaml) {
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose2D& pose = poses[i];
    const int index = static_cast<int>(i);
    if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw)) {
      throw PoseProblem(index, "pose " + std::to_string(i) + ": not a finite (x, y, yaw)");
    }
    unsigned mx, my;
    if (!costs.worldToMap(pose.x, pose.y, mx, my)) {
      throw PoseProblem(index, describePose(index, pose) + ": off the map " + map_yaml);
    }
    if (mx == 0 || my == 0 || mx + 1 == costs.sizeX() || my + 1 == costs.sizeY()) {
      throw PoseProblem(index, describePose(index, pose) +
                                   ": on the outer cells of the global costmap, which navfn treats as obstacles");
    }
    const int cost = costs.cost(mx, my);
    if (cost == kLethalObstacle || cost == kInscribedInflated) {
      throw PoseProblem(index, describePose(index, pose) +
                                   ": in an obstacle or the inscribed zone of the global costmap (cost " +
                                   std::to_string(cost) + ")");
    }
  }
}

std::unique_ptr<MarlMrtaTravel> planAllPairs(const std::string& map_yaml, const std::string& config_dir,
                                              const std::vector<Pose2D>& poses) {
  // move_base's own objects, as its node builds them; the global costmap has no observations.
  const MoveBaseConfig config = readMoveBaseConfig(ParamNode(loadMoveBaseParams(config_dir), "move_base"));
  MoveBaseCore core(config);
  const map::OccupancyMap occupancy = asPublished(map::loadMap(map_yaml));
  for (StaticLayer* layer : core.globalCostmap().layersOfType<StaticLayer>()) layer->setMap(occupancy);
  // No robot stands on the map: the obstacle layer clears the robot's footprint, which at some
  // pose of the map would open a hole in unknown space there (track_unknown_space: true).
  core.globalCostmap().updateMap(Pose2D{occupancy.origin_x - 1e6, occupancy.origin_y - 1e6, 0.0});
  const CostGrid& costs = core.globalCostmap().costmap();
  checkPoses(costs, poses, map_yaml);

  const int n = static_cast<int>(poses.size());
  auto travel = std::make_unique<MarlMrtaTravel>();
  travel->n = n;
  travel->max_speed = std::min(config.dwa.limits.max_vel_x, config.dwa.limits.max_vel_trans);
  travel->xy.resize(static_cast<size_t>(n) * n);
  std::vector<int> failures(n, 0);
  std::vector<std::string> first_failure(n);
  for (int a = 0; a < n; ++a) {
    std::vector<Pose2D> goals;
    std::vector<int> goal_index;
    for (int b = 0; b < n; ++b) {
      if (b == a) continue;
      goals.push_back(poses[b]);
      goal_index.push_back(b);
    }
    // One wave from a for all goals, with move_base's default tolerance. No path variability:
    // the planner draws its first random field with a goal, which this does not set.
    const std::vector<PlanResult> plans = core.planner().makePlans(costs, poses[a], goals);
    for (size_t k = 0; k < plans.size(); ++k) {
      const int b = goal_index[k];
      if (!plans[k].ok()) {
        for (int pose : {a, b}) {
          if (failures[pose]++ == 0) first_failure[pose] = plans[k].message;
        }
        continue;
      }
      std::vector<double>& xy = travel->xy[static_cast<size_t>(a) * n + b];
      xy.reserve(2 * plans[k].path.size());
      for (const Pose2D& point : plans[k].path) {
        xy.push_back(point.x);
        xy.push_back(point.y);
      }
    }
  }
  // The pose with the most failed plans (the first on a tie): a pose walled in fails all of its
  // own, the others one each towards it.
  int worst = 0;
  for (int i = 1; i < n; ++i) {
    if (failures[i] > failures[worst]) worst = i;
  }
  if (n > 0 && failures[worst] > 0) {
    throw PoseProblem(worst, describePose(worst, poses[worst]) + ": cannot be reached: " +
                                 std::to_string(failures[worst]) + " of the " + std::to_string(2 * (n - 1)) +
                                 " plans from and to it failed (" + first_failure[worst] + ")");
  }
  return travel;
}

void writeError(char* error, int error_size, const std::string& message) {
  if (!error || error_size <= 0) return;
  const size_t length = std::min(message.size(), static_cast<size_t>(error_size) - 1);
  std::memcpy(error, message.data(), length);
  error[length] = '\0';
}

const std::vector<double>* pathOf(const MarlMrtaTravel* travel, int a, int b) {
  if (!travel || a < 0 || b < 0 || a >= travel->n || b >= travel->n || a == b) return nullptr;
  return &travel->xy[static_cast<size_t>(a) * travel->n + b];
}

}  // namespace
}  // namespace nav
}  // namespace marl_mrta

extern "C" {

MarlMrtaTravel* marl_mrta_travel_plan(const char* map_yaml, const char* nav_config_dir, int n, const double* poses,
                                      char* error, int error_size, int* failed_node) {
  using namespace marl_mrta::nav;
  writeError(error, error_size, "");
  if (failed_node) *failed_node = -1;
  try {
    if (!map_yaml || !nav_config_dir) throw std::invalid_argument("the map file and the navigation directory must be given");
    if (n < 0 || (n > 0 && !poses)) throw std::invalid_argument("poses: expected n >= 0 poses of 3 doubles");
    std::vector<Pose2D> pose_list(n);
    for (int i = 0; i < n; ++i) pose_list[i] = {poses[3 * i], poses[3 * i + 1], poses[3 * i + 2]};
    return planAllPairs(map_yaml, nav_config_dir, pose_list).release();
  } catch (const PoseProblem& problem) {
    if (failed_node) *failed_node = problem.pose();
    writeError(error, error_size, problem.what());
  } catch (const std::exception& problem) {
    writeError(error, error_size, problem.what());
  } catch (...) {
    writeError(error, error_size, "travel planning failed with an unknown error");
  }
  return nullptr;
}

double marl_mrta_travel_max_speed(const MarlMrtaTravel* travel) { return travel ? travel->max_speed : 0.0; }

int marl_mrta_travel_path_size(const MarlMrtaTravel* travel, int a, int b) {
  const std::vector<double>* xy = marl_mrta::nav::pathOf(travel, a, b);
  return xy ? static_cast<int>(xy->size() / 2) : 0;
}

void marl_mrta_travel_path(const MarlMrtaTravel* travel, int a, int b, double* xy) {
  const std::vector<double>* path = marl_mrta::nav::pathOf(travel, a, b);
  if (path && xy) std::copy(path->begin(), path->end(), xy);
}

void marl_mrta_travel_free(MarlMrtaTravel* travel) { delete travel; }

int marl_mrta_map_read(const char* map_yaml, signed char* data, int capacity, int* width, int* height, char* error,
                       int error_size) {
  using namespace marl_mrta::nav;
  writeError(error, error_size, "");
  try {
    if (!map_yaml) throw std::invalid_argument("the map file must be given");
    const marl_mrta::map::OccupancyMap map = marl_mrta::map::loadMap(map_yaml);
    if (width) *width = map.width;
    if (height) *height = map.height;
    const int cells = static_cast<int>(map.data.size());
    if (data && capacity >= cells) std::copy(map.data.begin(), map.data.end(), data);
    return cells;
  } catch (const std::exception& problem) {
    writeError(error, error_size, problem.what());
  }
  return -1;
}

}  // extern "C"
