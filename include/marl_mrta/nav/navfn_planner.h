// Global planner after navfn: a wavefront (Dijkstra with navfn's planar interpolation) over
// the costmap from the robot's cell until the goal is reached, then the path from the goal
// down the potential's gradient back to the robot, reversed.
//
// Cell traversal cost is 50 + 0.8·cost; costs >= 253 (inscribed, lethal) are obstacles;
// unknown (255) costs 253 when allow_unknown, else is an obstacle. With default_tolerance the
// goal may be replaced by the reachable cell closest to it within that distance.
//
// Path variability (off by default): a seeded, smooth random field raises the cost of free
// cells by up to `path_variability`·50, redrawn per goal, so that the same start and goal
// can give different paths. The same seed gives the same sequence of fields.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "marl_mrta/nav/costmap_grid.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace nav {

struct NavfnConfig {
  bool allow_unknown = true;
  double default_tolerance = 0.0;   // [m]
  double planner_window_x = 0.0;    // [m] accepted for compatibility (unused, as in navfn)
  double planner_window_y = 0.0;
  bool visualize_potential = false;
  double path_variability = 0.0;         // 0 = off; up to this fraction of the neutral cost is added
  double path_variability_length = 1.0;  // [m] spacing of the random field's lattice
  int path_variability_seed = 0;
};

struct PlanResult {
  enum class Status { kOk, kStartOutsideMap, kGoalOutsideMap, kGoalInObstacle, kNoPath };
  Status status = Status::kNoPath;
  std::vector<Pose2D> path;  // world frame of the costmap; last pose = goal (with its yaw)
  std::string message;       // why planning failed (one line)
  bool ok() const { return status == Status::kOk; }
};

class NavfnPlanner {
 public:
  static constexpr float kPotentialHigh = 1.0e10f;
  static constexpr uint8_t kCostObstacle = 254;  // navfn's COST_OBS
  static constexpr uint8_t kCostNeutral = 50;
  static constexpr float kCostFactor = 0.8f;

  explicit NavfnPlanner(const NavfnConfig& config);
  const NavfnConfig& config() const { return config_; }

  // navfn's translation of a costmap value into a traversal cost.
  static uint8_t traversalCost(uint8_t costmap_value, bool allow_unknown);

  // Draws the next random field (call once per new goal). No effect when variability is off.
  void drawVariation();
  // Plans with the configured default tolerance.
  PlanResult makePlan(const CostGrid& costmap, const Pose2D& start, const Pose2D& goal);
  PlanResult makePlan(const CostGrid& costmap, const Pose2D& start, const Pose2D& goal, double tolerance);
  // The plans from `start` to each of `goals`, each exactly what makePlan(costmap, start, goal)
  // returns, from one wavefront: the wave spreads from the start as for a single goal, and each
  // goal's path is traced at the moment makePlan would have stopped the wave for that goal.
  std::vector<PlanResult> makePlans(const CostGrid& costmap, const Pose2D& start, const std::vector<Pose2D>& goals);
  std::vector<PlanResult> makePlans(const CostGrid& costmap, const Pose2D& start, const std::vector<Pose2D>& goals,
                                    double tolerance);

  // Potential of the last plan, row-major over the costmap (kPotentialHigh = not reached).
  const std::vector<float>& potential() const { return potential_; }
  // Number of cells whose potential was updated in the last plan (work measure).
  size_t lastExpansions() const { return expansions_; }

 private:
  void setupCosts(const CostGrid& costmap, unsigned start_index);
  // The wavefront from `source`, spread by cycles; spreadWave runs cycles until one ends with a
  // potential on one of `stop_cells` (true) or the wave is over (false), and can be resumed.
  void startWave(unsigned source);
  bool spreadWave(const std::vector<unsigned>& stop_cells);
  void updateCell(unsigned n);
  // The tolerance search and the path down the potential as it stands now.
  PlanResult finishPlan(const CostGrid& costmap, const Pose2D& start, unsigned start_index, const Pose2D& goal,
                        double tolerance);
  bool tracePath(unsigned from, unsigned to, std::vector<float>& path_x, std::vector<float>& path_y);
  float gradientAt(unsigned n);
  double variationAt(unsigned mx, unsigned my, double resolution) const;

  NavfnConfig config_;
  unsigned nx_ = 0, ny_ = 0, ns_ = 0;
  std::vector<uint8_t> cost_;
  std::vector<float> potential_;
  std::vector<float> grad_x_, grad_y_;
  std::vector<unsigned> gradients_cached_;  // cells of grad_x_/grad_y_ set since the last trace began
  std::vector<char> pending_;
  std::vector<unsigned> current_, next_, overflow_;
  float threshold_ = 0.0f;
  size_t wave_cycles_left_ = 0;
  size_t expansions_ = 0;
  uint64_t variation_draw_ = 0;  // 0 = no field drawn yet
};

}  // namespace nav
}  // namespace marl_mrta
