// Obstacles seen by the sensors (costmap_2d's ObstacleLayer): each observation marks its
// points (closer than obstacle_range) lethal and clears the cells along each ray up to
// raytrace_range; the robot's own footprint is cleared.
#pragma once

#include <deque>
#include <string>
#include <vector>

#include "marl_mrta/nav/layer.h"

namespace marl_mrta {
namespace nav {

struct ObservationSourceConfig {
  std::string name;
  std::string topic;
  std::string sensor_frame;       // "" = the frame of the message
  std::string data_type = "LaserScan";
  double observation_persistence = 0.0;  // [s] 0 = only the latest observation
  double expected_update_rate = 0.0;     // [s] 0 = never stale
  double min_obstacle_height = 0.0;      // [m]
  double max_obstacle_height = 2.0;      // [m]
  bool inf_is_valid = false;             // inf readings clear up to range_max
  bool clearing = false;
  bool marking = true;
  double obstacle_range = 2.5;  // [m]
  double raytrace_range = 3.0;  // [m]
};

struct ObstacleLayerConfig {
  bool footprint_clearing_enabled = true;
  double max_obstacle_height = 2.0;
  int combination_method = 1;  // 0: overwrite, 1: maximum
  bool track_unknown_space = false;
  std::vector<ObservationSourceConfig> sources;
};

struct Point3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

// Points of one sensor reading in the costmap's global frame.
struct Observation {
  Point3 origin;  // sensor position
  std::vector<Point3> points;
  double obstacle_range = 2.5;
  double raytrace_range = 3.0;
  double stamp = 0.0;  // [s]
};

struct LaserScanData {
  double angle_min = 0.0, angle_increment = 0.0;
  double range_min = 0.0, range_max = 0.0;
  std::vector<float> ranges;
  double stamp = 0.0;
};

// Sensor placement in the global frame (planar: roll and pitch are taken as zero).
struct SensorPose {
  double x = 0.0, y = 0.0, z = 0.0, yaw = 0.0;
};

// laser_geometry's projection: readings outside [range_min, range_max] are dropped; with
// inf_is_valid, +inf becomes range_max - 1e-4 (clears, never marks past obstacle_range).
Observation laserScanToObservation(const LaserScanData& scan, const SensorPose& sensor,
                                   const ObservationSourceConfig& source);

class ObstacleLayer : public Layer {
 public:
  ObstacleLayer(std::string name, const ObstacleLayerConfig& config);

  const ObstacleLayerConfig& config() const { return config_; }
  // A new observation from source number `source_index` (order of config().sources).
  void addObservation(size_t source_index, Observation observation);
  // Forgets every cell outside (or, with invert_area, inside) the square of side `side`
  // centred on (x, y) (clear_costmap_recovery).
  void clearArea(double x, double y, double side, bool invert_area);
  const CostGrid& grid() const { return grid_; }

  void matchSize(const LayeredCostmap& master) override;
  void onFootprintChanged(const LayeredCostmap& master) override;
  void updateBounds(const Pose2D& robot, Bounds& bounds) override;
  void updateCosts(CostGrid& master, const CellWindow& window) override;
  void reset() override;
  bool isCurrent(double now) const override;

 private:
  struct SourceBuffer {
    std::deque<Observation> observations;
    size_t unapplied = 0;  // observations not yet written into a non-rolling grid
    double last_arrival = -1.0;
  };
  void raytraceFreespace(const Observation& observation, Bounds& bounds);
  void markObstacles(const Observation& observation, Bounds& bounds);
  void touchCell(unsigned index, Bounds& bounds) const;

  ObstacleLayerConfig config_;
  CostGrid grid_;
  bool rolling_ = false;
  Polygon footprint_;
  std::vector<SourceBuffer> buffers_;
  std::vector<double> footprint_x_, footprint_y_;
  Bounds extra_bounds_;
  // Cells cleared during this update that were lethal before it: a change only if no
  // observation marks them again (keeps the update area to what really changed).
  std::vector<unsigned> cleared_;
  std::vector<char> was_lethal_;
};

}  // namespace nav
}  // namespace marl_mrta
