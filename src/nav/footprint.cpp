#include "marl_mrta/nav/footprint.h"

#include <algorithm>
#include <cmath>
#include <cctype>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace marl_mrta {
namespace nav {
namespace {

double distanceToSegment(double px, double py, double x0, double y0, double x1, double y1) {
  const double dx = x1 - x0, dy = y1 - y0;
  const double length_sq = dx * dx + dy * dy;
  double t = length_sq > 0.0 ? ((px - x0) * dx + (py - y0) * dy) / length_sq : 0.0;
  t = std::min(1.0, std::max(0.0, t));
  return std::hypot(px - (x0 + t * dx), py - (y0 + t * dy));
}

}  // namespace

void validateFootprint(const Polygon& footprint) {
  if (footprint.size() < 3) {
    throw std::invalid_argument("a footprint needs at least 3 points, got " + std::to_string(footprint.size()));
  }
  for (const Point2& p : footprint) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) throw std::invalid_argument("a footprint point is not finite");
  }
}

Polygon parseFootprintString(const std::string& text) {
  // Grammar: '[' point (',' point)* ']' with point = '[' number ',' number ']'.
  Polygon polygon;
  size_t pos = 0;
  auto skip_space = [&]() {
    while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
  };
  auto expect = [&](char c) {
    skip_space();
    if (pos >= text.size() || text[pos] != c) {
      throw std::invalid_argument(std::string("expected '") + c + "' at character " + std::to_string(pos) +
                                  " of \"" + text + "\"");
    }
    ++pos;
  };
  auto number = [&]() {
    skip_space();
    const char* begin = text.c_str() + pos;
    char* end = nullptr;
    const double value = std::strtod(begin, &end);
    if (end == begin) {
      throw std::invalid_argument("expected a number at character " + std::to_string(pos) + " of \"" + text + "\"");
    }
    pos += end - begin;
    return value;
  };
  expect('[');
  skip_space();
  while (true) {
    expect('[');
    Point2 p;
    p.x = number();
    expect(',');
    p.y = number();
    expect(']');
    polygon.push_back(p);
    skip_space();
    if (pos < text.size() && text[pos] == ',') {
      ++pos;
      continue;
    }
    expect(']');
    break;
  }
  skip_space();
  if (pos != text.size()) throw std::invalid_argument("unexpected text after the footprint in \"" + text + "\"");
  validateFootprint(polygon);
  return polygon;
}

Polygon footprintFromRadius(double radius) {
  constexpr int kPoints = 16;
  Polygon polygon;
  for (int i = 0; i < kPoints; ++i) {
    const double angle = i * 2.0 * M_PI / kPoints;
    polygon.push_back({radius * std::cos(angle), radius * std::sin(angle)});
  }
  return polygon;
}

Polygon padFootprint(const Polygon& footprint, double padding) {
  auto sign0 = [](double v) { return v < 0.0 ? -1.0 : (v > 0.0 ? 1.0 : 0.0); };
  Polygon padded = footprint;
  for (Point2& p : padded) {
    p.x += sign0(p.x) * padding;
    p.y += sign0(p.y) * padding;
  }
  return padded;
}

double inscribedRadius(const Polygon& footprint) {
  double min_dist = std::numeric_limits<double>::max();
  for (size_t i = 0; i < footprint.size(); ++i) {
    const Point2& a = footprint[i];
    const Point2& b = footprint[(i + 1) % footprint.size()];
    min_dist = std::min({min_dist, std::hypot(a.x, a.y), distanceToSegment(0.0, 0.0, a.x, a.y, b.x, b.y)});
  }
  return footprint.size() < 3 ? 0.0 : min_dist;
}

double circumscribedRadius(const Polygon& footprint) {
  double max_dist = 0.0;
  for (const Point2& p : footprint) max_dist = std::max(max_dist, std::hypot(p.x, p.y));
  return max_dist;
}

void transformFootprint(const Polygon& footprint, const Pose2D& pose, std::vector<double>& xs,
                        std::vector<double>& ys) {
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  xs.resize(footprint.size());
  ys.resize(footprint.size());
  for (size_t i = 0; i < footprint.size(); ++i) {
    xs[i] = pose.x + c * footprint[i].x - s * footprint[i].y;
    ys[i] = pose.y + s * footprint[i].x + c * footprint[i].y;
  }
}

std::string footprintToString(const Polygon& footprint) {
  std::ostringstream out;
  out << "[";
  for (size_t i = 0; i < footprint.size(); ++i) {
    out << (i ? ", " : "") << "[" << footprint[i].x << ", " << footprint[i].y << "]";
  }
  out << "]";
  return out.str();
}

}  // namespace nav
}  // namespace marl_mrta
