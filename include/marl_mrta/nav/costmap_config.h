// A costmap's configuration read from its parameter namespace (costmap_2d::Costmap2DROS),
// in either style:
//  - pre-Hydro (no `plugins`): `static_map` adds a static layer, an obstacle layer is always
//    there (top-level obstacle_range, raytrace_range, observation_sources + one namespace per
//    source), and an inflation layer (top-level inflation_radius, cost_scaling_factor);
//  - `plugins: [{name, type}]` with costmap_2d::StaticLayer / ObstacleLayer / InflationLayer,
//    each configured in its own namespace.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "marl_mrta/nav/footprint.h"
#include "marl_mrta/nav/inflation_layer.h"
#include "marl_mrta/nav/layered_costmap.h"
#include "marl_mrta/nav/obstacle_layer.h"
#include "marl_mrta/nav/param_tree.h"
#include "marl_mrta/nav/static_layer.h"

namespace marl_mrta {
namespace nav {

struct LayerSpec {
  enum class Kind { kStatic, kObstacle, kInflation };
  Kind kind = Kind::kStatic;
  std::string name;
  StaticLayerConfig static_layer;
  ObstacleLayerConfig obstacle_layer;
  InflationLayerConfig inflation_layer;
};

struct CostmapConfig {
  std::string name;                        // namespace, e.g. "global_costmap"
  std::string global_frame = "map";
  std::string robot_base_frame = "base_link";
  double update_frequency = 5.0;           // [Hz]
  double publish_frequency = 0.0;          // [Hz] 0 = never
  double transform_tolerance = 0.3;        // [s]
  bool rolling_window = false;
  bool track_unknown_space = false;
  bool always_send_full_costmap = false;
  double width = 10.0, height = 10.0;      // [m] used when no static map sizes the grid
  double resolution = 0.05;                // [m]
  double origin_x = 0.0, origin_y = 0.0;   // [m]
  Polygon footprint;                       // as configured (unpadded)
  double footprint_padding = 0.01;         // [m]
  bool pre_hydro_style = false;
  std::vector<LayerSpec> layers;

  Polygon paddedFootprint() const { return padFootprint(footprint, footprint_padding); }
};

// Reads one costmap namespace. Throws ParamError naming the parameter.
CostmapConfig readCostmapConfig(const ParamNode& costmap_ns);
// Reads `footprint` (list or string) or else `robot_radius`. Throws ParamError.
Polygon readFootprint(const ParamNode& ns, double default_radius);
// The layered costmap described by a configuration (grid sized from width/height/resolution;
// a static layer resizes it when its map arrives).
std::unique_ptr<LayeredCostmap> buildCostmap(const CostmapConfig& config);

}  // namespace nav
}  // namespace marl_mrta
