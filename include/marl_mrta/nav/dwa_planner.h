// Dynamic Window Approach local planner after dwa_local_planner (noetic).
//
// Velocities (vx, vy, vθ) are sampled evenly inside the window reachable within one control
// period (v ± acc_lim·sim_period, clipped to the limits), each sample is rolled out at constant
// velocity for sim_time and scored by the critics listed in scoreTrajectory(); the cheapest
// valid sample wins. No valid sample => cost < 0 and a zero command.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "marl_mrta/nav/costmap_grid.h"
#include "marl_mrta/nav/footprint.h"

namespace marl_mrta {
namespace nav {

struct Velocity2D {
  double x = 0.0;      // [m/s] forward
  double y = 0.0;      // [m/s] left
  double theta = 0.0;  // [rad/s]
};

struct LocalPlannerLimits {
  double max_vel_trans = 0.55, min_vel_trans = 0.1;  // [m/s] |(vx, vy)|
  double max_vel_x = 0.55, min_vel_x = 0.0;          // [m/s]
  double max_vel_y = 0.1, min_vel_y = -0.1;          // [m/s]
  double max_vel_theta = 1.0, min_vel_theta = 0.4;   // [rad/s] |vθ|
  double acc_lim_x = 2.5, acc_lim_y = 2.5, acc_lim_theta = 3.2, acc_lim_trans = 0.1;
  double trans_stopped_vel = 0.1, theta_stopped_vel = 0.1;
  double xy_goal_tolerance = 0.1, yaw_goal_tolerance = 0.1;
  bool prune_plan = true;
};

struct DwaConfig {
  LocalPlannerLimits limits;
  double sim_time = 1.7;                  // [s]
  double sim_granularity = 0.025;         // [m] between rollout points
  double angular_sim_granularity = 0.1;   // [rad]
  int vx_samples = 3, vy_samples = 10, vth_samples = 20;
  double sim_period = 0.05;               // [s] 1 / controller_frequency
  double path_distance_bias = 32.0;
  double goal_distance_bias = 24.0;
  double occdist_scale = 0.01;
  double twirling_scale = 0.0;
  double forward_point_distance = 0.325;  // [m]
  double stop_time_buffer = 0.2;          // [s] (as in dwa_local_planner: not used in scoring)
  double scaling_speed = 0.25;            // [m/s] (as in dwa_local_planner: not used in scoring)
  double max_scaling_factor = 0.2;
  double oscillation_reset_dist = 0.05;   // [m]
  double oscillation_reset_angle = 0.2;   // [rad]
  bool latch_xy_goal_tolerance = false;
  bool use_dwa = true;
};

struct Trajectory {
  double xv = 0.0, yv = 0.0, thetav = 0.0;  // the sampled command
  double cost = -1.0;                        // < 0: invalid
  double time_delta = 0.0;
  std::vector<Pose2D> points;
  std::vector<double> cos_yaw, sin_yaw;  // of each point's yaw, computed once for all critics
};

// Distance (in cells, 4-connected) of every local-costmap cell to a set of target cells,
// through cells that are not lethal, inscribed or unknown (base_local_planner's MapGrid).
class MapGrid {
 public:
  void reset(unsigned size_x, unsigned size_y);
  // Targets: every cell of the plan inside the map (path distance).
  void setTargetCells(const CostGrid& costmap, const std::vector<Pose2D>& plan);
  // Target: the last plan cell inside the map (goal distance).
  void setLocalGoal(const CostGrid& costmap, const std::vector<Pose2D>& plan);
  // That cell, false when the plan never enters the map.
  static bool localGoalCell(const CostGrid& costmap, const std::vector<Pose2D>& plan, unsigned& goal_index);
  // Target: one cell (-1: none, every cell unreachable).
  void setGoalCell(const CostGrid& costmap, int goal_index);
  int goalCell() const { return goal_index_; }
  double distance(unsigned mx, unsigned my) const { return target_dist_[my * size_x_ + mx]; }
  double obstacleCosts() const { return static_cast<double>(size_x_) * size_y_; }
  double unreachableCellCosts() const { return obstacleCosts() + 1.0; }

 private:
  void propagate(const CostGrid& costmap, std::vector<unsigned>& queue);
  unsigned size_x_ = 0, size_y_ = 0;
  int goal_index_ = -1;  // setGoalCell's target
  std::vector<double> target_dist_;
  std::vector<char> marked_;
};

// Cost of a footprint placed at a pose on a costmap (base_local_planner's CostmapModel +
// ObstacleCostFunction): the highest cell cost on the footprint outline and under its centre,
// or a negative value when the outline touches a lethal or unknown cell or leaves the map.
double footprintCostAt(const CostGrid& costmap, const Polygon& footprint, const Pose2D& pose);
// The same with cos/sin of the pose's yaw already known.
double footprintCostAt(const CostGrid& costmap, const Polygon& footprint, const Pose2D& pose, double cos_yaw,
                       double sin_yaw);

// Intermediate points so that consecutive plan points are at most `resolution` apart.
std::vector<Pose2D> adjustPlanResolution(const std::vector<Pose2D>& plan, double resolution);

class DwaPlanner {
 public:
  explicit DwaPlanner(const DwaConfig& config);
  const DwaConfig& config() const { return config_; }

  // A new global plan: oscillation flags are forgotten.
  void resetOscillationFlags();
  // Per cycle, before findBestPath/checkTrajectory: the local costmap, the robot pose and the
  // plan (both in the costmap frame) and the (padded) footprint.
  void updatePlanAndLocalCosts(const CostGrid& costmap, const Pose2D& pose, const std::vector<Pose2D>& plan,
                               const Polygon& footprint);
  // The best sampled trajectory; cost < 0 when every sample was discarded.
  Trajectory findBestPath(const Pose2D& pose, const Velocity2D& velocity);
  // Scores one command (used to check stopping and in-place rotation commands).
  bool checkTrajectory(const Pose2D& pose, const Velocity2D& velocity, const Velocity2D& sample);

  // Every sample of the dynamic window rolled out and scored whole (cost < 0: discarded), as
  // dwa_local_planner publishes them on trajectory_cloud (publish_traj_pc). Call it before
  // findBestPath(), which moves the oscillation flags the scores read; it changes nothing.
  std::vector<Trajectory> exploreSamples(const Pose2D& pose, const Velocity2D& velocity) const;
  // A local-costmap cell as dwa_local_planner's cost_cloud (publish_cost_grid_pc) shows it:
  // cell centre [m, costmap frame], path and goal distance [cells], cell cost, and
  // path_distance_bias·res·path + goal_distance_bias·res·goal + occdist_scale·occ.
  struct CellCosts {
    double x, y, path, goal, occupancy, total;
  };
  // Every cell of the last updatePlanAndLocalCosts() but those in or next to an obstacle
  // (cost >= 253) and those the path distance cannot reach, as dwa_local_planner leaves them out.
  std::vector<CellCosts> cellCosts() const;

  // The velocity samples for a current velocity (dynamic window).
  std::vector<Velocity2D> velocitySamples(const Velocity2D& velocity) const;
  // Rolls a sample out; false (no points) when it is below the minimum or above the maximum speed.
  bool generateTrajectory(const Pose2D& pose, const Velocity2D& sample, Trajectory& trajectory) const;
  // Sum of scaled critic costs, or the negative code of the critic that discarded it. A sum
  // above best_cost (>= 0) may be left partial: the sample cannot win.
  double scoreTrajectory(const Trajectory& trajectory, double best_cost) const;
  double footprintCost(const Pose2D& pose) const { return footprintCostAt(*costmap_, footprint_, pose); }
  size_t lastSampleCount() const { return last_sample_count_; }
  // When findBestPath() found no valid sample: how many samples were discarded with each
  // negative code scoreTrajectory() returns (the index; discardReason() names it).
  const std::array<size_t, 8>& lastDiscards() const { return last_discards_; }
  // What a discard code (2-7, the negated return of scoreTrajectory()) means, for log lines.
  static const char* discardReason(size_t code);

 private:
  struct OscillationFlags {
    bool forward_pos = false, forward_neg = false, strafe_pos = false, strafe_neg = false;
    bool rot_pos = false, rot_neg = false;
    bool forward_pos_only = false, forward_neg_only = false, strafe_pos_only = false, strafe_neg_only = false;
    bool rot_pos_only = false, rot_neg_only = false;
    bool restricted() const {
      return forward_pos_only || forward_neg_only || strafe_pos_only || strafe_neg_only || rot_pos_only ||
             rot_neg_only;
    }
  };
  // The headings of a rollout and their cos/sin: the same for every sample of equal vθ and
  // step count from one pose, so computed once per findBestPath() for each.
  struct YawSequence {
    double theta = 0.0;
    int steps = -1;  // -1: none yet
    std::vector<double> yaw, cos_yaw, sin_yaw;
  };
  // Rolls out with the headings in `yaws`, computing them first unless they are this sample's.
  bool generateTrajectory(const Pose2D& pose, const Velocity2D& sample, Trajectory& trajectory,
                          YawSequence& yaws) const;
  double oscillationCost(const Trajectory& trajectory) const;
  double obstacleCost(const Trajectory& trajectory) const;
  double mapGridCost(const MapGrid& grid, const Trajectory& trajectory, double x_shift, bool stop_on_failure) const;
  // scoreTrajectory() without the obstacle critic; stops summing once above bound (>= 0).
  double scoreWithoutObstacles(const Trajectory& trajectory, double bound) const;
  // The distance critics' weights: dwa_local_planner scales path_distance_bias and
  // goal_distance_bias by the costmap's resolution (their distances are in cells).
  double pathScale() const { return (costmap_ ? costmap_->resolution() : 0.05) * config_.path_distance_bias; }
  double goalScale() const { return (costmap_ ? costmap_->resolution() : 0.05) * config_.goal_distance_bias; }
  void updateOscillationFlags(const Pose2D& pose, const Trajectory& chosen);

  DwaConfig config_;
  const CostGrid* costmap_ = nullptr;
  Polygon footprint_;
  MapGrid path_grid_, goal_grid_, goal_front_grid_;
  bool front_shares_goal_grid_ = false;  // the nose's local goal is goal_grid_'s
  double alignment_scale_ = 0.0;
  OscillationFlags oscillation_;
  Pose2D prev_stationary_pose_;
  size_t last_sample_count_ = 0;
  std::array<size_t, 8> last_discards_{};
  Trajectory rollout_;  // findBestPath's rollout buffer, reused from sample to sample
  std::vector<YawSequence> yaw_cache_;  // findBestPath's, by position in the vθ samples
};

}  // namespace nav
}  // namespace marl_mrta
