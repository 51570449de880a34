#include "marl_mrta/map/occupancy_map.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <sstream>

namespace marl_mrta {
namespace map {

MapError::MapError(const std::string& file, const std::string& field, const std::string& problem)
    : std::runtime_error(file + ": " + field + ": " + problem), file_(file), field_(field), problem_(problem) {}

bool OccupancyMap::worldToCell(double wx, double wy, int& cx, int& cy) const {
  double dx = wx - origin_x;
  double dy = wy - origin_y;
  if (origin_yaw != 0.0) {  // into the grid's own axes
    const double c = std::cos(origin_yaw), s = std::sin(origin_yaw);
    const double gx = c * dx + s * dy;
    dy = -s * dx + c * dy;
    dx = gx;
  }
  const double fx = dx / resolution;
  const double fy = dy / resolution;
  // Written so that NaN fails too.
  if (!(fx >= 0.0 && fy >= 0.0 && fx < width && fy < height)) return false;
  cx = static_cast<int>(fx);
  cy = static_cast<int>(fy);
  return true;
}

void OccupancyMap::cellToWorld(int cx, int cy, double& wx, double& wy) const {
  const double gx = (cx + 0.5) * resolution;
  const double gy = (cy + 0.5) * resolution;
  if (origin_yaw == 0.0) {
    wx = origin_x + gx;
    wy = origin_y + gy;
    return;
  }
  const double c = std::cos(origin_yaw), s = std::sin(origin_yaw);
  wx = origin_x + c * gx - s * gy;
  wy = origin_y + s * gx + c * gy;
}

namespace {

const char* const kKnownFields[] = {"image", "resolution", "origin", "negate",
                                    "occupied_thresh", "free_thresh", "mode"};

std::string directoryOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

template <typename T>
std::string str(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double readNumber(const YAML::Node& root, const std::string& file, const std::string& field) {
  const YAML::Node node = root[field];
  if (!node) throw MapError(file, field, "missing");
  if (!node.IsScalar()) throw MapError(file, field, "must be a number");
  double value = 0.0;
  if (!YAML::convert<double>::decode(node, value) || !std::isfinite(value)) {
    throw MapError(file, field, "must be a finite number, got '" + node.Scalar() + "'");
  }
  return value;
}

bool readNegate(const YAML::Node& root, const std::string& file) {
  const YAML::Node node = root["negate"];
  if (!node) throw MapError(file, "negate", "missing");
  int as_int = 0;
  bool as_bool = false;
  if (node.IsScalar() && YAML::convert<int>::decode(node, as_int) && (as_int == 0 || as_int == 1)) {
    return as_int == 1;
  }
  if (node.IsScalar() && YAML::convert<bool>::decode(node, as_bool)) return as_bool;
  throw MapError(file, "negate", "must be 0 or 1, got '" + (node.IsScalar() ? node.Scalar() : "a non-scalar") + "'");
}

}  // namespace

MapYaml readMapYaml(const std::string& yaml_path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml_path);
  } catch (const YAML::BadFile&) {
    throw MapError(yaml_path, "yaml", "cannot open file");
  } catch (const YAML::ParserException& e) {
    throw MapError(yaml_path, "yaml",
                   "malformed YAML at line " + str(e.mark.line + 1) + ", column " + str(e.mark.column + 1) +
                       ": " + e.msg);
  }
  if (!root.IsMap()) throw MapError(yaml_path, "yaml", "must be a mapping of map_server fields");
  const std::set<std::string> known(std::begin(kKnownFields), std::end(kKnownFields));
  for (const auto& entry : root) {
    const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : "?";
    if (!known.count(key)) {
      throw MapError(yaml_path, key,
                     "unknown field (expected image, resolution, origin, negate, occupied_thresh, free_thresh, mode)");
    }
  }

  MapYaml out;
  const YAML::Node image = root["image"];
  if (!image) throw MapError(yaml_path, "image", "missing");
  if (!image.IsScalar() || image.Scalar().empty()) throw MapError(yaml_path, "image", "must be a file name");
  out.image_path = image.Scalar();
  if (out.image_path[0] != '/') out.image_path = directoryOf(yaml_path) + "/" + out.image_path;

  out.resolution = readNumber(root, yaml_path, "resolution");
  if (out.resolution <= 0.0) {
    throw MapError(yaml_path, "resolution", "must be positive, got " + root["resolution"].Scalar());
  }

  const YAML::Node origin = root["origin"];
  if (!origin) throw MapError(yaml_path, "origin", "missing");
  if (!origin.IsSequence() || origin.size() != 3) {
    throw MapError(yaml_path, "origin", "must be a list [x, y, yaw] of 3 numbers");
  }
  double xyz[3];
  for (size_t i = 0; i < 3; ++i) {
    if (!origin[i].IsScalar() || !YAML::convert<double>::decode(origin[i], xyz[i]) || !std::isfinite(xyz[i])) {
      throw MapError(yaml_path, "origin", "element " + str(i) + " must be a finite number");
    }
  }
  out.origin_x = xyz[0];
  out.origin_y = xyz[1];
  out.origin_yaw = xyz[2];

  out.negate = readNegate(root, yaml_path);
  out.occupied_thresh = readNumber(root, yaml_path, "occupied_thresh");
  out.free_thresh = readNumber(root, yaml_path, "free_thresh");
  if (out.occupied_thresh < 0.0 || out.occupied_thresh > 1.0) {
    throw MapError(yaml_path, "occupied_thresh", "must be in [0, 1], got " + str(out.occupied_thresh));
  }
  if (out.free_thresh < 0.0 || out.free_thresh > out.occupied_thresh) {
    throw MapError(yaml_path, "free_thresh",
                   "must be in [0, occupied_thresh = " + str(out.occupied_thresh) + "], got " + str(out.free_thresh));
  }

  if (const YAML::Node mode = root["mode"]) {
    const std::string name = mode.IsScalar() ? mode.Scalar() : "";
    if (name == "trinary") {
      out.mode = MapMode::kTrinary;
    } else if (name == "scale") {
      out.mode = MapMode::kScale;
    } else if (name == "raw") {
      out.mode = MapMode::kRaw;
    } else {
      throw MapError(yaml_path, "mode", "'" + name + "' is not one of trinary, scale, raw");
    }
  }
  return out;
}

std::vector<int8_t> occupancyFromImage(const MapImage& image, const MapYaml& params) {
  std::vector<int8_t> cells(static_cast<size_t>(image.width) * image.height);
  const int channels = image.channels;
  // As map_server: alpha is averaged in with the colours in trinary mode, and its "alpha" is the
  // last channel, an RGB pixel's blue included.
  const int averaged = (params.mode == MapMode::kTrinary || channels != 4) ? channels : channels - 1;
  for (int row = 0; row < image.height; ++row) {
    const int cy = image.height - 1 - row;  // the image's top row is the grid's last row
    for (int cx = 0; cx < image.width; ++cx) {
      const uint8_t* pixel = &image.pixels[(static_cast<size_t>(row) * image.width + cx) * channels];
      int sum = 0;
      for (int k = 0; k < averaged; ++k) sum += pixel[k];
      double mean = sum / static_cast<double>(averaged);
      const int alpha = channels == 1 ? 1 : pixel[channels - 1];
      if (params.negate) mean = 255.0 - mean;
      // Truncation to an unsigned byte, then to int8, as map_server stores it.
      uint8_t value = 0;
      if (params.mode == MapMode::kRaw) {
        value = static_cast<uint8_t>(mean);
      } else {
        const double occ = (255.0 - mean) / 255.0;
        if (occ > params.occupied_thresh) {
          value = 100;
        } else if (occ < params.free_thresh) {
          value = 0;
        } else if (params.mode == MapMode::kTrinary || alpha < 1) {
          value = 255;  // -1 as int8
        } else if (params.occupied_thresh > params.free_thresh) {
          const double ratio = (occ - params.free_thresh) / (params.occupied_thresh - params.free_thresh);
          value = static_cast<uint8_t>(1 + 98 * ratio);
        } else {
          value = 0;  // equal thresholds, occ on them: map_server's 0/0 ratio, which x86 turns into 0
        }
      }
      cells[static_cast<size_t>(cy) * image.width + cx] = static_cast<int8_t>(value);
    }
  }
  return cells;
}

OccupancyMap loadMap(const std::string& yaml_path) {
  const MapYaml params = readMapYaml(yaml_path);
  MapImage image;
  try {
    image = readMapImage(params.image_path);
  } catch (const MapError& e) {
    // A missing image is a problem of the YAML's `image` field; a bad image of the image file.
    if (e.field() == "file") throw MapError(yaml_path, "image", "'" + params.image_path + "': " + e.problem());
    throw;
  }
  OccupancyMap map;
  map.resolution = params.resolution;
  map.origin_x = params.origin_x;
  map.origin_y = params.origin_y;
  map.origin_yaw = params.origin_yaw;
  map.width = image.width;
  map.height = image.height;
  map.data = occupancyFromImage(image, params);
  map.yaml_path = yaml_path;
  return map;
}

}  // namespace map
}  // namespace marl_mrta
