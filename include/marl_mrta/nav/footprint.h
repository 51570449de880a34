// Robot footprint: a polygon in the robot frame (base_footprint), as costmap_2d's footprint tools.
#pragma once

#include <string>
#include <vector>

#include "marl_mrta/geometry.h"

namespace marl_mrta {
namespace nav {

using ::marl_mrta::Pose2D;

struct Point2 {
  double x = 0.0;
  double y = 0.0;
};
using Polygon = std::vector<Point2>;

// "[[x, y], [x, y], ...]" (the string form costmap_2d accepts); at least 3 points.
// Throws std::invalid_argument with a one-line description of the problem.
Polygon parseFootprintString(const std::string& text);
// Checks a polygon given as a list (>= 3 finite points). Throws std::invalid_argument.
void validateFootprint(const Polygon& footprint);
// A 16-gon approximating a circle (costmap_2d's footprint for `robot_radius`).
Polygon footprintFromRadius(double radius);
// Pushes every vertex `padding` outward along each axis (costmap_2d's footprint_padding).
Polygon padFootprint(const Polygon& footprint, double padding);
// Distance from the robot centre to the closest edge (inscribed) / farthest vertex (circumscribed).
double inscribedRadius(const Polygon& footprint);
double circumscribedRadius(const Polygon& footprint);
// The footprint placed at a pose: world coordinates of the vertices.
void transformFootprint(const Polygon& footprint, const Pose2D& pose, std::vector<double>& xs,
                        std::vector<double>& ys);
std::string footprintToString(const Polygon& footprint);

}  // namespace nav
}  // namespace marl_mrta
