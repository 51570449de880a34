#include "marl_mrta/nav/costmap_config.h"

#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace nav {
namespace {

// The first of the namespaces (innermost first) holding `key`, like ros::NodeHandle::searchParam.
double searchDouble(const std::vector<const ParamNode*>& scopes, const std::string& key, double default_value) {
  for (const ParamNode* scope : scopes) {
    if (scope->has(key)) return scope->getDouble(key, default_value, 0.0);
  }
  return default_value;
}

// Costmap2DROS copies some of the costmap's own parameters into a layer's namespace, over the
// layer's own value (copyParentParameters; for the pre-Hydro static layer, loadOldParameters):
// the namespace such a key is read from. The layer's value, overwritten there, counts as read.
const ParamNode& fromCostmap(const ParamNode& layer_ns, const ParamNode* costmap_ns, const std::string& key) {
  if (costmap_ns == nullptr || !costmap_ns->has(key)) return layer_ns;
  layer_ns.accept(key);
  return *costmap_ns;
}

ObservationSourceConfig readSource(const ParamNode& layer_ns, const std::string& source_name,
                                   const std::vector<const ParamNode*>& outer_scopes, const ParamNode* costmap_ns) {
  if (!layer_ns.has(source_name)) {
    throw ParamError(layer_ns.pathOf(source_name), "observation source listed in observation_sources but not defined");
  }
  const ParamNode source_ns = layer_ns.child(source_name);
  ObservationSourceConfig source;
  source.name = source_name;
  source.topic = source_ns.getString("topic", source_name);
  source.sensor_frame = source_ns.getString("sensor_frame", "");
  source.observation_persistence = source_ns.getDouble("observation_persistence", 0.0, 0.0);
  source.expected_update_rate = source_ns.getDouble("expected_update_rate", 0.0, 0.0);
  source.data_type = source_ns.getString("data_type", "PointCloud");
  if (source.data_type != "LaserScan") {
    throw ParamError(source_ns.pathOf("data_type"),
                     "'" + source.data_type + "' is not supported by the built-in costmap (use LaserScan)");
  }
  source.min_obstacle_height = source_ns.getDouble("min_obstacle_height", 0.0);
  source.max_obstacle_height = source_ns.getDouble("max_obstacle_height", 2.0);
  source.inf_is_valid = source_ns.getBool("inf_is_valid", false);
  source.clearing = source_ns.getBool("clearing", false);
  source.marking = source_ns.getBool("marking", true);
  // Searched upwards from the source's namespace (ros::NodeHandle::searchParam), the layer's
  // holding the costmap's value where it has one.
  auto search = [&](const std::string& key, double default_value) {
    std::vector<const ParamNode*> scopes{&source_ns};
    for (const ParamNode* scope : outer_scopes) {
      scopes.push_back(scope == &layer_ns ? &fromCostmap(layer_ns, costmap_ns, key) : scope);
    }
    return searchDouble(scopes, key, default_value);
  };
  source.obstacle_range = search("obstacle_range", 2.5);
  source.raytrace_range = search("raytrace_range", 3.0);
  return source;
}

// costmap_ns: the costmap whose parameters are copied over the layer's (plugin style); null when
// the costmap's namespace is the layer's (pre-Hydro).
ObstacleLayerConfig readObstacleLayer(const ParamNode& layer_ns, const std::vector<const ParamNode*>& scopes,
                                      const ParamNode* costmap_ns) {
  ObstacleLayerConfig config;
  config.footprint_clearing_enabled = layer_ns.getBool("footprint_clearing_enabled", true);
  config.max_obstacle_height =
      fromCostmap(layer_ns, costmap_ns, "max_obstacle_height").getDouble("max_obstacle_height", 2.0);
  config.combination_method = layer_ns.getInt("combination_method", 1, 0, 1);
  // Default: the costmap's own track_unknown_space, false unless set (copied over when it is).
  config.track_unknown_space =
      fromCostmap(layer_ns, costmap_ns, "track_unknown_space").getBool("track_unknown_space", false);
  layer_ns.accept("enabled");
  std::istringstream names(layer_ns.getString("observation_sources", ""));
  std::string name;
  while (names >> name) config.sources.push_back(readSource(layer_ns, name, scopes, costmap_ns));
  return config;
}

StaticLayerConfig readStaticLayer(const ParamNode& layer_ns, const ParamNode* costmap_ns) {
  // These four are the costmap's own when it sets them, in either style (copied over the layer's).
  // Unset, track_unknown_space is the layer's default, true: the map's unknown cells stay unknown
  // here (an obstacle layer that does not track unknown space then writes them free).
  auto pick = [&](const std::string& key) -> const ParamNode& { return fromCostmap(layer_ns, costmap_ns, key); };
  StaticLayerConfig config;
  config.map_topic = pick("map_topic").getString("map_topic", "map");
  config.unknown_cost_value = pick("unknown_cost_value").getInt("unknown_cost_value", -1, -1, 255);
  config.lethal_cost_threshold = pick("lethal_cost_threshold").getInt("lethal_cost_threshold", 100, 1, 255);
  config.track_unknown_space = pick("track_unknown_space").getBool("track_unknown_space", true);
  config.first_map_only = layer_ns.getBool("first_map_only", false);
  config.subscribe_to_updates = layer_ns.getBool("subscribe_to_updates", false);
  config.use_maximum = layer_ns.getBool("use_maximum", false);
  config.trinary_costmap = layer_ns.getBool("trinary_costmap", true);
  layer_ns.accept("enabled");
  return config;
}

InflationLayerConfig readInflationLayer(const ParamNode& layer_ns, const ParamNode* costmap_ns) {
  InflationLayerConfig config;
  config.inflation_radius =
      fromCostmap(layer_ns, costmap_ns, "inflation_radius").getDouble("inflation_radius", 0.55, 0.0);
  config.cost_scaling_factor =
      fromCostmap(layer_ns, costmap_ns, "cost_scaling_factor").getDouble("cost_scaling_factor", 10.0, 0.0);
  config.inflate_unknown = layer_ns.getBool("inflate_unknown", false);
  layer_ns.accept("enabled");
  return config;
}

void readPreHydroLayers(const ParamNode& ns, CostmapConfig& config) {
  if (ns.getBool("static_map", false)) {
    LayerSpec spec;
    spec.kind = LayerSpec::Kind::kStatic;
    spec.name = "static_layer";
    spec.static_layer = readStaticLayer(ns.child("static_layer"), &ns);
    config.layers.push_back(spec);
  }
  const std::string map_type = ns.getString("map_type", "costmap");
  if (map_type != "costmap") {
    throw ParamError(ns.pathOf("map_type"), "'" + map_type + "' is not supported by the built-in costmap (use costmap)");
  }
  // The top level plays the obstacle layer's namespace, as after costmap_2d's parameter move.
  LayerSpec obstacle;
  obstacle.kind = LayerSpec::Kind::kObstacle;
  obstacle.name = "obstacle_layer";
  obstacle.obstacle_layer = readObstacleLayer(ns, {&ns}, nullptr);
  config.layers.push_back(obstacle);
  LayerSpec inflation;
  inflation.kind = LayerSpec::Kind::kInflation;
  inflation.name = "inflation_layer";
  inflation.inflation_layer = readInflationLayer(ns, nullptr);
  config.layers.push_back(inflation);
}

void readPluginLayers(const ParamNode& ns, CostmapConfig& config) {
  const YAML::Node plugins = ns.raw("plugins");
  if (!plugins.IsSequence()) throw ParamError(ns.pathOf("plugins"), "expected a list of {name, type}");
  for (size_t i = 0; i < plugins.size(); ++i) {
    const YAML::Node entry = plugins[i];
    const std::string where = ns.pathOf("plugins") + "[" + std::to_string(i) + "]";
    if (!entry.IsMap() || !entry["name"] || !entry["type"] || !entry["name"].IsScalar() || !entry["type"].IsScalar()) {
      throw ParamError(where, "expected {name: ..., type: ...}");
    }
    LayerSpec spec;
    spec.name = entry["name"].Scalar();
    const std::string type = entry["type"].Scalar();
    const ParamNode layer_ns = ns.child(spec.name);
    if (type == "costmap_2d::StaticLayer") {
      spec.kind = LayerSpec::Kind::kStatic;
      spec.static_layer = readStaticLayer(layer_ns, &ns);
    } else if (type == "costmap_2d::ObstacleLayer") {
      spec.kind = LayerSpec::Kind::kObstacle;
      spec.obstacle_layer = readObstacleLayer(layer_ns, {&layer_ns, &ns}, &ns);
    } else if (type == "costmap_2d::InflationLayer") {
      spec.kind = LayerSpec::Kind::kInflation;
      spec.inflation_layer = readInflationLayer(layer_ns, &ns);
    } else {
      throw ParamError(where, "layer type '" + type + "' is not available in the built-in costmap");
    }
    config.layers.push_back(spec);
  }
}

}  // namespace

Polygon readFootprint(const ParamNode& ns, double default_radius) {
  const YAML::Node value = ns.raw("footprint");
  const std::string where = ns.pathOf("footprint");
  if (!value.IsDefined()) {
    const double radius = ns.getDouble("robot_radius", default_radius, 0.0);
    return footprintFromRadius(radius);
  }
  ns.accept("robot_radius");
  try {
    if (value.IsScalar()) return parseFootprintString(value.Scalar());
    if (!value.IsSequence()) throw std::invalid_argument("expected a list of [x, y] points");
    Polygon polygon;
    for (size_t i = 0; i < value.size(); ++i) {
      const YAML::Node point = value[i];
      double x = 0.0, y = 0.0;
      if (!point.IsSequence() || point.size() != 2 || !YAML::convert<double>::decode(point[0], x) ||
          !YAML::convert<double>::decode(point[1], y)) {
        throw std::invalid_argument("point " + std::to_string(i) + " is not a pair of numbers [x, y]");
      }
      polygon.push_back({x, y});
    }
    validateFootprint(polygon);
    return polygon;
  } catch (const std::invalid_argument& error) {
    throw ParamError(where, error.what());
  }
}

CostmapConfig readCostmapConfig(const ParamNode& ns) {
  CostmapConfig config;
  config.name = ns.path().substr(ns.path().rfind('/') + 1);
  config.global_frame = ns.getString("global_frame", "map");
  config.robot_base_frame = ns.getString("robot_base_frame", "base_link");
  config.update_frequency = ns.getDouble("update_frequency", 5.0, 0.0);
  config.publish_frequency = ns.getDouble("publish_frequency", 0.0, 0.0);
  config.transform_tolerance = ns.getDouble("transform_tolerance", 0.3, 0.0);
  config.rolling_window = ns.getBool("rolling_window", false);
  config.track_unknown_space = ns.getBool("track_unknown_space", false);
  config.always_send_full_costmap = ns.getBool("always_send_full_costmap", false);
  config.resolution = ns.getDouble("resolution", 0.05, 1e-6);
  config.width = ns.getDouble("width", 10.0, 0.0);
  config.height = ns.getDouble("height", 10.0, 0.0);
  config.origin_x = ns.getDouble("origin_x", 0.0);
  config.origin_y = ns.getDouble("origin_y", 0.0);
  config.footprint_padding = ns.getDouble("footprint_padding", 0.01);
  config.footprint = readFootprint(ns, 0.46);
  ns.accept("footprint_topic");
  ns.accept("publish_voxel_map");
  config.pre_hydro_style = !ns.has("plugins");
  if (config.pre_hydro_style) {
    readPreHydroLayers(ns, config);
  } else {
    readPluginLayers(ns, config);
  }
  return config;
}

std::unique_ptr<LayeredCostmap> buildCostmap(const CostmapConfig& config) {
  auto costmap = std::make_unique<LayeredCostmap>(config.rolling_window, config.track_unknown_space);
  const unsigned size_x = static_cast<unsigned>(std::lround(config.width / config.resolution));
  const unsigned size_y = static_cast<unsigned>(std::lround(config.height / config.resolution));
  costmap->resizeMap(size_x, size_y, config.resolution, config.origin_x, config.origin_y);
  costmap->setFootprint(config.paddedFootprint());
  for (const LayerSpec& spec : config.layers) {
    switch (spec.kind) {
      case LayerSpec::Kind::kStatic:
        costmap->addLayer(std::make_unique<StaticLayer>(spec.name, spec.static_layer, *costmap));
        break;
      case LayerSpec::Kind::kObstacle:
        costmap->addLayer(std::make_unique<ObstacleLayer>(spec.name, spec.obstacle_layer));
        break;
      case LayerSpec::Kind::kInflation:
        costmap->addLayer(std::make_unique<InflationLayer>(spec.name, spec.inflation_layer));
        break;
    }
  }
  return costmap;
}

}  // namespace nav
}  // namespace marl_mrta
