// Cell costs shared by the costmap layers and the planners (costmap_2d's values).
#pragma once

#include <cstdint>

namespace marl_mrta {
namespace nav {

constexpr uint8_t kNoInformation = 255;       // unknown space
constexpr uint8_t kLethalObstacle = 254;      // an obstacle in the cell
constexpr uint8_t kInscribedInflated = 253;   // robot centre here => footprint hits an obstacle
constexpr uint8_t kFreeSpace = 0;

}  // namespace nav
}  // namespace marl_mrta
