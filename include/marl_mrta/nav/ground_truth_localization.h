// Localisation from a simulator's ground truth (fake_localization): map -> odom such that
// map -> odom -> base is the true pose. The one computation of the fake_localization node and
// of the simulator's own `publish_localization`, so that both publish the same bits.
#pragma once

#include "marl_mrta/nav/local_controller.h"

namespace marl_mrta {
namespace nav {

// A pose as the transform from its frame to its parent, and back.
Transform2D asTransform(const Pose2D& pose);
// a after b: first b, then a.
Transform2D compose(const Transform2D& a, const Transform2D& b);
Transform2D inverse(const Transform2D& t);

// map -> base: the true pose (map frame), moved by `offset` (fake_localization's delta_* and
// initialpose).
Transform2D mapToBase(const Pose2D& truth, const Transform2D& offset);
// map -> odom from map -> base (mapToBase) and the odometry pose (odom frame) of the same instant.
Transform2D mapToOdom(const Transform2D& map_base, const Pose2D& odom);

}  // namespace nav
}  // namespace marl_mrta
