#include "marl_mrta/nav/ground_truth_localization.h"

#include <cmath>

namespace marl_mrta {
namespace nav {

Transform2D asTransform(const Pose2D& pose) { return {pose.x, pose.y, pose.yaw}; }

Transform2D compose(const Transform2D& a, const Transform2D& b) {
  const Pose2D p = a.apply({b.x, b.y, b.yaw});
  return {p.x, p.y, p.yaw};
}

Transform2D inverse(const Transform2D& t) {
  const double c = std::cos(t.yaw), s = std::sin(t.yaw);
  return {-(c * t.x + s * t.y), -(-s * t.x + c * t.y), -t.yaw};
}

Transform2D mapToBase(const Pose2D& truth, const Transform2D& offset) { return compose(offset, asTransform(truth)); }

Transform2D mapToOdom(const Transform2D& map_base, const Pose2D& odom) {
  return compose(map_base, inverse(asTransform(odom)));
}

}  // namespace nav
}  // namespace marl_mrta
