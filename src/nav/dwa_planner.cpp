#include "marl_mrta/nav/dwa_planner.h"

#include <algorithm>
#include <cmath>

namespace marl_mrta {
namespace nav {
namespace {

// Evenly spaced samples from min to max (both included); 0 is inserted when the range
// crosses it, so that "stop this axis" is always a candidate (base_local_planner's VelocityIterator).
std::vector<double> sampleRange(double min, double max, int count) {
  std::vector<double> samples;
  if (min == max) {
    samples.push_back(min);
    return samples;
  }
  count = std::max(2, count);
  const double step = (max - min) / (count - 1);
  double next = min;
  for (int j = 0; j < count - 1; ++j) {
    const double current = next;
    next += step;
    samples.push_back(current);
    if (current < 0.0 && next > 0.0) samples.push_back(0.0);
  }
  samples.push_back(max);
  return samples;
}

// The sample nearest the current velocity: what the robot is doing, usually close to the best.
size_t closestSample(const std::vector<Velocity2D>& samples, const Velocity2D& velocity) {
  size_t closest = 0;
  double closest_sq = -1.0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const double dx = samples[i].x - velocity.x, dy = samples[i].y - velocity.y;
    const double dth = samples[i].theta - velocity.theta;
    const double sq = dx * dx + dy * dy + dth * dth;
    if (closest_sq < 0.0 || sq < closest_sq) {
      closest_sq = sq;
      closest = i;
    }
  }
  return closest;
}

bool isBlocking(uint8_t cost) {
  return cost == kLethalObstacle || cost == kInscribedInflated || cost == kNoInformation;
}

// Motion one way along an axis (stock oscillation flags): `same` is this direction's flag,
// `opposite` the other direction's. After motion the other way, the axis is restricted to this
// direction (`only`); true when that happened.
bool moveAlong(bool& same, bool& opposite, bool& only) {
  const bool reversed = opposite;
  if (reversed) only = true;
  opposite = false;
  same = true;
  return reversed;
}

// One axis's flags for the chosen velocity `v` along it; true when a restriction was set.
bool updateAxisFlags(double v, bool& pos, bool& neg, bool& pos_only, bool& neg_only) {
  if (v < 0.0) return moveAlong(neg, pos, neg_only);
  if (v > 0.0) return moveAlong(pos, neg, pos_only);
  return false;
}

}  // namespace

// ----------------------------------------------------------------------------- MapGrid

void MapGrid::reset(unsigned size_x, unsigned size_y) {
  size_x_ = size_x;
  size_y_ = size_y;
  goal_index_ = -1;
  target_dist_.assign(static_cast<size_t>(size_x) * size_y, unreachableCellCosts());
  marked_.assign(static_cast<size_t>(size_x) * size_y, 0);
}

std::vector<Pose2D> adjustPlanResolution(const std::vector<Pose2D>& plan, double resolution) {
  std::vector<Pose2D> out;
  if (plan.empty()) return out;
  out.push_back(plan.front());
  const double min_sq = resolution * resolution;
  for (size_t i = 1; i < plan.size(); ++i) {
    const Pose2D& last = plan[i - 1];
    const double sq = (plan[i].x - last.x) * (plan[i].x - last.x) + (plan[i].y - last.y) * (plan[i].y - last.y);
    if (sq > min_sq) {
      const int steps = static_cast<int>(std::ceil(std::sqrt(sq) / resolution));
      for (int j = 1; j < steps; ++j) {
        out.push_back({last.x + j * (plan[i].x - last.x) / steps, last.y + j * (plan[i].y - last.y) / steps,
                       plan[i].yaw});
      }
    }
    out.push_back(plan[i]);
  }
  return out;
}

void MapGrid::propagate(const CostGrid& costmap, std::vector<unsigned>& queue) {
  // Breadth first over 4 neighbours: the distance is a count of cells.
  for (size_t head = 0; head < queue.size(); ++head) {
    const unsigned current = queue[head];
    const unsigned cx = current % size_x_, cy = current / size_x_;
    const double next_dist = target_dist_[current] + 1.0;
    auto visit = [&](unsigned check) {
      if (marked_[check]) return;
      marked_[check] = 1;
      if (isBlocking(costmap.cells()[check])) {
        target_dist_[check] = obstacleCosts();
        return;
      }
      if (next_dist < target_dist_[check]) target_dist_[check] = next_dist;
      queue.push_back(check);
    };
    if (cx > 0) visit(current - 1);
    if (cx + 1 < size_x_) visit(current + 1);
    if (cy > 0) visit(current - size_x_);
    if (cy + 1 < size_y_) visit(current + size_x_);
  }
}

void MapGrid::setTargetCells(const CostGrid& costmap, const std::vector<Pose2D>& plan) {
  reset(costmap.sizeX(), costmap.sizeY());
  std::vector<unsigned> queue;
  bool started = false;
  for (const Pose2D& p : adjustPlanResolution(plan, costmap.resolution())) {
    unsigned mx, my;
    if (costmap.worldToMap(p.x, p.y, mx, my) && costmap.cost(mx, my) != kNoInformation) {
      const unsigned index = costmap.index(mx, my);
      target_dist_[index] = 0.0;
      marked_[index] = 1;
      queue.push_back(index);
      started = true;
    } else if (started) {
      break;  // the plan left the local map
    }
  }
  if (started) propagate(costmap, queue);
}

bool MapGrid::localGoalCell(const CostGrid& costmap, const std::vector<Pose2D>& plan, unsigned& goal_index) {
  bool started = false;
  for (const Pose2D& p : adjustPlanResolution(plan, costmap.resolution())) {
    unsigned mx, my;
    if (costmap.worldToMap(p.x, p.y, mx, my) && costmap.cost(mx, my) != kNoInformation) {
      goal_index = costmap.index(mx, my);
      started = true;
    } else if (started) {
      break;
    }
  }
  return started;
}

void MapGrid::setLocalGoal(const CostGrid& costmap, const std::vector<Pose2D>& plan) {
  unsigned goal_index = 0;
  setGoalCell(costmap, localGoalCell(costmap, plan, goal_index) ? static_cast<int>(goal_index) : -1);
}

void MapGrid::setGoalCell(const CostGrid& costmap, int goal_index) {
  reset(costmap.sizeX(), costmap.sizeY());
  goal_index_ = goal_index;
  if (goal_index < 0) return;
  std::vector<unsigned> queue{static_cast<unsigned>(goal_index)};
  target_dist_[goal_index] = 0.0;
  marked_[goal_index] = 1;
  propagate(costmap, queue);
}

double footprintCostAt(const CostGrid& map, const Polygon& footprint, const Pose2D& pose) {
  return footprintCostAt(map, footprint, pose, std::cos(pose.yaw), std::sin(pose.yaw));
}

double footprintCostAt(const CostGrid& map, const Polygon& footprint, const Pose2D& pose, double c, double s) {
  unsigned cx, cy;
  if (!map.worldToMap(pose.x, pose.y, cx, cy)) return -7.0;
  const size_t n = footprint.size();
  double outline_cost = 0.0;
  if (n < 3) {
    const uint8_t c = map.cost(cx, cy);
    if (isBlocking(c)) return -6.0;
    outline_cost = c;
  } else {
    // Vertex cells; small fixed storage because this runs for every rollout point.
    constexpr size_t kMaxVertices = 64;
    if (n > kMaxVertices) return -6.0;
    unsigned xs[kMaxVertices], ys[kMaxVertices];
    for (size_t i = 0; i < n; ++i) {
      const double wx = pose.x + c * footprint[i].x - s * footprint[i].y;
      const double wy = pose.y + s * footprint[i].x + c * footprint[i].y;
      if (!map.worldToMap(wx, wy, xs[i], ys[i])) return -6.0;
    }
    const uint8_t* cells = map.cells().data();
    bool blocked = false;
    uint8_t worst = 0;
    for (size_t i = 0; i < n && !blocked; ++i) {
      const size_t j = (i + 1) % n;
      map.raytraceLine(
          [&](unsigned index) {
            const uint8_t cost = cells[index];
            if (cost == kLethalObstacle || cost == kNoInformation) blocked = true;
            worst = std::max(worst, cost);
          },
          xs[i], ys[i], xs[j], ys[j]);
    }
    if (blocked) return -6.0;
    outline_cost = worst;
  }
  return std::max(outline_cost, static_cast<double>(map.cost(cx, cy)));
}

// ----------------------------------------------------------------------------- DwaPlanner

DwaPlanner::DwaPlanner(const DwaConfig& config) : config_(config) {
  config_.vx_samples = std::max(1, config_.vx_samples);
  config_.vy_samples = std::max(1, config_.vy_samples);
  config_.vth_samples = std::max(1, config_.vth_samples);
}

void DwaPlanner::resetOscillationFlags() { oscillation_ = OscillationFlags{}; }

void DwaPlanner::updatePlanAndLocalCosts(const CostGrid& costmap, const Pose2D& pose,
                                         const std::vector<Pose2D>& plan, const Polygon& footprint) {
  costmap_ = &costmap;
  footprint_ = footprint;
  if (plan.empty()) return;
  path_grid_.setTargetCells(costmap, plan);
  goal_grid_.setLocalGoal(costmap, plan);
  // The nose (forward_point_distance ahead) is drawn to a point that far past the goal, seen
  // from the robot, so that the final turn does not pull the nose sideways.
  const Pose2D& goal = plan.back();
  std::vector<Pose2D> front_plan = plan;
  const double angle_to_goal = std::atan2(goal.y - pose.y, goal.x - pose.x);
  front_plan.back().x += config_.forward_point_distance * std::cos(angle_to_goal);
  front_plan.back().y += config_.forward_point_distance * std::sin(angle_to_goal);
  // Where the plan leaves the local map before its end, the nose's local goal is the goal
  // grid's own cell: the same grid.
  unsigned front_cell = 0;
  const int front_goal = MapGrid::localGoalCell(costmap, front_plan, front_cell) ? static_cast<int>(front_cell) : -1;
  front_shares_goal_grid_ = front_goal == goal_grid_.goalCell();
  if (!front_shares_goal_grid_) goal_front_grid_.setGoalCell(costmap, front_goal);
  // Keeping the nose on the path destabilises the last forward_point_distance: switch it off there.
  const double sq_dist = (pose.x - goal.x) * (pose.x - goal.x) + (pose.y - goal.y) * (pose.y - goal.y);
  // (The alignment critic reads path_grid_: the same target cells.)
  alignment_scale_ = sq_dist > config_.forward_point_distance * config_.forward_point_distance ? pathScale() : 0.0;
}

std::vector<Velocity2D> DwaPlanner::velocitySamples(const Velocity2D& velocity) const {
  const LocalPlannerLimits& l = config_.limits;
  const double dt = config_.sim_period;
  // The dynamic window: what one control period of acceleration can reach, within the limits.
  const double max_x = std::min(l.max_vel_x, velocity.x + l.acc_lim_x * dt);
  const double min_x = std::max(l.min_vel_x, velocity.x - l.acc_lim_x * dt);
  const double max_y = std::min(l.max_vel_y, velocity.y + l.acc_lim_y * dt);
  const double min_y = std::max(l.min_vel_y, velocity.y - l.acc_lim_y * dt);
  const double max_th = std::min(l.max_vel_theta, velocity.theta + l.acc_lim_theta * dt);
  const double min_th = std::max(-l.max_vel_theta, velocity.theta - l.acc_lim_theta * dt);
  std::vector<Velocity2D> samples;
  for (double vx : sampleRange(min_x, max_x, config_.vx_samples)) {
    for (double vy : sampleRange(min_y, max_y, config_.vy_samples)) {
      for (double vth : sampleRange(min_th, max_th, config_.vth_samples)) samples.push_back({vx, vy, vth});
    }
  }
  return samples;
}

bool DwaPlanner::generateTrajectory(const Pose2D& pose, const Velocity2D& sample, Trajectory& trajectory) const {
  YawSequence yaws;
  return generateTrajectory(pose, sample, trajectory, yaws);
}

bool DwaPlanner::generateTrajectory(const Pose2D& pose, const Velocity2D& sample, Trajectory& trajectory,
                                    YawSequence& yaws) const {
  const LocalPlannerLimits& l = config_.limits;
  constexpr double kEps = 1e-4;
  // Cleared, not replaced: the point buffers keep their capacity from sample to sample.
  trajectory.points.clear();
  trajectory.cos_yaw.clear();
  trajectory.sin_yaw.clear();
  trajectory.cost = -1.0;
  trajectory.time_delta = 0.0;
  trajectory.xv = sample.x;
  trajectory.yv = sample.y;
  trajectory.thetav = sample.theta;
  const double speed = std::hypot(sample.x, sample.y);
  // Too slow both in translation and in rotation: the robot would not really move.
  if (l.min_vel_trans >= 0 && speed + kEps < l.min_vel_trans && l.min_vel_theta >= 0 &&
      std::fabs(sample.theta) + kEps < l.min_vel_theta) {
    return false;
  }
  if (l.max_vel_trans >= 0 && speed - kEps > l.max_vel_trans) return false;
  const int steps = static_cast<int>(std::ceil(std::max(speed * config_.sim_time / config_.sim_granularity,
                                                        std::fabs(sample.theta) * config_.sim_time /
                                                            config_.angular_sim_granularity)));
  if (steps == 0) return false;
  const double dt = config_.sim_time / steps;
  trajectory.time_delta = dt;
  if (yaws.steps != steps || yaws.theta != sample.theta) {
    // The headings of this rollout, for every later sample of the same vθ and step count.
    yaws.theta = sample.theta;
    yaws.steps = steps;
    yaws.yaw.clear();
    yaws.cos_yaw.clear();
    yaws.sin_yaw.clear();
    double yaw = pose.yaw;
    for (int i = 0; i < steps; ++i) {
      yaws.yaw.push_back(yaw);
      yaws.cos_yaw.push_back(std::cos(yaw));
      yaws.sin_yaw.push_back(std::sin(yaw));
      yaw += sample.theta * dt;
    }
  }
  trajectory.points.reserve(steps);
  trajectory.cos_yaw = yaws.cos_yaw;
  trajectory.sin_yaw = yaws.sin_yaw;
  double x = pose.x, y = pose.y;
  for (int i = 0; i < steps; ++i) {
    const double c = yaws.cos_yaw[i], s = yaws.sin_yaw[i];
    trajectory.points.push_back({x, y, yaws.yaw[i]});
    x += (sample.x * c - sample.y * s) * dt;
    y += (sample.x * s + sample.y * c) * dt;
  }
  return true;
}

double DwaPlanner::oscillationCost(const Trajectory& t) const {
  const OscillationFlags& f = oscillation_;
  if ((f.forward_pos_only && t.xv < 0.0) || (f.forward_neg_only && t.xv > 0.0) ||
      (f.strafe_pos_only && t.yv < 0.0) || (f.strafe_neg_only && t.yv > 0.0) ||
      (f.rot_pos_only && t.thetav < 0.0) || (f.rot_neg_only && t.thetav > 0.0)) {
    return -5.0;
  }
  return 0.0;
}

double DwaPlanner::obstacleCost(const Trajectory& trajectory) const {
  double cost = 0.0;
  for (size_t i = 0; i < trajectory.points.size(); ++i) {
    const double c =
        footprintCostAt(*costmap_, footprint_, trajectory.points[i], trajectory.cos_yaw[i], trajectory.sin_yaw[i]);
    if (c < 0.0) return c;
    cost = std::max(cost, c);
  }
  return cost;
}

double DwaPlanner::mapGridCost(const MapGrid& grid, const Trajectory& trajectory, double x_shift,
                               bool stop_on_failure) const {
  double cost = 0.0;
  const size_t last = trajectory.points.size() - 1;
  for (size_t i = 0; i < trajectory.points.size(); ++i) {
    const Pose2D& p = trajectory.points[i];
    const double px = p.x + x_shift * trajectory.cos_yaw[i], py = p.y + x_shift * trajectory.sin_yaw[i];
    unsigned mx, my;
    if (!costmap_->worldToMap(px, py, mx, my)) return -4.0;
    // Only the last point's distance counts; the others matter only where they can discard.
    if (!stop_on_failure && i != last) continue;
    const double d = grid.distance(mx, my);
    if (stop_on_failure) {
      if (d == grid.obstacleCosts()) return -3.0;
      if (d == grid.unreachableCellCosts()) return -2.0;
    }
    cost = d;
  }
  return cost;
}

double DwaPlanner::scoreWithoutObstacles(const Trajectory& trajectory, double bound) const {
  const double path_scale = pathScale();
  const double goal_scale = goalScale();
  const double fpd = config_.forward_point_distance;
  // The critics of dwa_local_planner but the obstacle one, which scoreTrajectory() adds last
  // (dwa_local_planner runs it second): scale, cost (negative = discard), what it prefers.
  struct Critic {
    double scale;
    double (*score)(const DwaPlanner&, const Trajectory&, double fpd);
  };
  const Critic critics[] = {
      // oscillation: forbids reversing a direction until the robot has moved oscillation_reset_dist
      {1.0, [](const DwaPlanner& p, const Trajectory& t, double) { return p.oscillationCost(t); }},
      // goal front (goal_distance_bias): the nose point's distance to the local goal
      {goal_scale,
       [](const DwaPlanner& p, const Trajectory& t, double f) {
         return p.mapGridCost(p.front_shares_goal_grid_ ? p.goal_grid_ : p.goal_front_grid_, t, f, false);
       }},
      // alignment (path_distance_bias, 0 near the goal): the nose point's distance to the path
      // (the path critic's grid: dwa_local_planner gives both critics the same target cells)
      {alignment_scale_,
       [](const DwaPlanner& p, const Trajectory& t, double f) { return p.mapGridCost(p.path_grid_, t, f, false); }},
      // path (path_distance_bias): the end point's distance to the global path
      {path_scale,
       [](const DwaPlanner& p, const Trajectory& t, double) { return p.mapGridCost(p.path_grid_, t, 0.0, true); }},
      // goal (goal_distance_bias): the end point's distance to the local goal
      {goal_scale,
       [](const DwaPlanner& p, const Trajectory& t, double) { return p.mapGridCost(p.goal_grid_, t, 0.0, true); }},
      // twirling (twirling_scale): prefers less spinning
      {config_.twirling_scale, [](const DwaPlanner&, const Trajectory& t, double) { return std::fabs(t.thetav); }},
  };
  double total = 0.0;
  for (const Critic& critic : critics) {
    if (critic.scale == 0.0) continue;
    const double cost = critic.score(*this, trajectory, fpd);
    if (cost < 0.0) return cost;
    total += cost * critic.scale;
    // Costs only add up: once above the bound, it stays above.
    if (bound >= 0.0 && total > bound) break;
  }
  return total;
}

double DwaPlanner::scoreTrajectory(const Trajectory& trajectory, double best_cost) const {
  const double partial = scoreWithoutObstacles(trajectory, best_cost);
  if (partial < 0.0 || config_.occdist_scale == 0.0 || (best_cost >= 0.0 && partial > best_cost)) return partial;
  // obstacle (occdist_scale): max footprint cost along the rollout; lethal contact discards
  const double obstacle = obstacleCost(trajectory);
  if (obstacle < 0.0) return obstacle;
  return partial + obstacle * config_.occdist_scale;
}

void DwaPlanner::updateOscillationFlags(const Pose2D& pose, const Trajectory& chosen) {
  if (chosen.cost < 0.0) return;
  OscillationFlags& f = oscillation_;
  bool flag_set = updateAxisFlags(chosen.xv, f.forward_pos, f.forward_neg, f.forward_pos_only, f.forward_neg_only);
  // Strafing and rotation flags only count when (almost) not translating.
  if (std::fabs(chosen.xv) <= config_.limits.min_vel_trans) {
    flag_set |= updateAxisFlags(chosen.yv, f.strafe_pos, f.strafe_neg, f.strafe_pos_only, f.strafe_neg_only);
    flag_set |= updateAxisFlags(chosen.thetav, f.rot_pos, f.rot_neg, f.rot_pos_only, f.rot_neg_only);
  }
  if (flag_set) prev_stationary_pose_ = pose;
  if (f.restricted()) {
    const double dx = pose.x - prev_stationary_pose_.x, dy = pose.y - prev_stationary_pose_.y;
    if (dx * dx + dy * dy > config_.oscillation_reset_dist * config_.oscillation_reset_dist ||
        std::fabs(pose.yaw - prev_stationary_pose_.yaw) > config_.oscillation_reset_angle) {
      resetOscillationFlags();
    }
  }
}

std::vector<Trajectory> DwaPlanner::exploreSamples(const Pose2D& pose, const Velocity2D& velocity) const {
  std::vector<Trajectory> explored;
  for (const Velocity2D& sample : velocitySamples(velocity)) {
    Trajectory rollout;
    if (!generateTrajectory(pose, sample, rollout)) continue;
    rollout.cost = scoreTrajectory(rollout, -1.0);
    explored.push_back(std::move(rollout));
  }
  return explored;
}

std::vector<DwaPlanner::CellCosts> DwaPlanner::cellCosts() const {
  std::vector<CellCosts> cells;
  if (costmap_ == nullptr) return cells;
  const double path_scale = pathScale(), goal_scale = goalScale();
  for (unsigned mx = 0; mx < costmap_->sizeX(); ++mx) {  // dwa_local_planner's order
    for (unsigned my = 0; my < costmap_->sizeY(); ++my) {
      const double path = path_grid_.distance(mx, my);
      const double goal = goal_grid_.distance(mx, my);
      const uint8_t occupancy = costmap_->cost(mx, my);
      if (path == path_grid_.obstacleCosts() || path == path_grid_.unreachableCellCosts() ||
          occupancy >= kInscribedInflated) {
        continue;
      }
      CellCosts cell{0.0, 0.0, path, goal, static_cast<double>(occupancy), 0.0};
      costmap_->mapToWorld(mx, my, cell.x, cell.y);
      cell.total = path_scale * path + goal_scale * goal + config_.occdist_scale * cell.occupancy;
      cells.push_back(cell);
    }
  }
  return cells;
}

Trajectory DwaPlanner::findBestPath(const Pose2D& pose, const Velocity2D& velocity) {
  // The winner is the valid sample of lowest total cost, the first in sample order on a tie.
  // The footprint check (obstacle critic) is the costly one, so it runs last and only as far
  // as needed. Costs only add up, so a sample whose partial sum exceeds a valid sample's
  // total cannot win:
  //  1. the sample closest to the current velocity is scored whole: a first bound;
  //  2. the other critics score every sample, dropping those above the bound;
  //  3. the rest get the footprint check in order of their partial cost, until a partial
  //     cost exceeds the best total found.
  struct Candidate {
    double partial;
    size_t sample;
  };
  const std::vector<Velocity2D> samples = velocitySamples(velocity);
  if (samples.empty()) {
    Trajectory none;
    none.cost = -7.0;
    last_sample_count_ = 0;
    return none;
  }
  // Samples run through vθ innermost: the k-th vθ of every (vx, vy) shares its headings.
  size_t n_theta = 1;
  while (n_theta < samples.size() && samples[n_theta].x == samples[0].x && samples[n_theta].y == samples[0].y) {
    ++n_theta;
  }
  yaw_cache_.resize(n_theta);
  for (YawSequence& yaws : yaw_cache_) yaws.steps = -1;  // headings start from this pose
  double best_cost = -1.0;
  size_t best_sample = 0;
  const size_t seed = closestSample(samples, velocity);
  if (generateTrajectory(pose, samples[seed], rollout_, yaw_cache_[seed % n_theta])) {
    const double cost = scoreTrajectory(rollout_, -1.0);
    if (cost >= 0.0) {
      best_cost = cost;
      best_sample = seed;
    }
  }
  std::vector<Candidate> candidates;
  candidates.reserve(samples.size());
  last_sample_count_ = 0;
  last_discards_.fill(0);
  // Without a valid sample there is no bound, so every sample is scored whole and the counts
  // below are complete exactly when they are reported (no valid sample).
  const auto discarded = [this](double code) { ++last_discards_[std::min<size_t>(7, static_cast<size_t>(-code))]; };
  for (size_t i = 0; i < samples.size(); ++i) {
    if (!generateTrajectory(pose, samples[i], rollout_, yaw_cache_[i % n_theta])) continue;
    ++last_sample_count_;
    if (best_cost >= 0.0 && i == seed) continue;
    const double partial = scoreWithoutObstacles(rollout_, best_cost);
    if (partial < 0.0) discarded(partial);
    if (partial >= 0.0 && (best_cost < 0.0 || partial <= best_cost)) candidates.push_back({partial, i});
  }
  // A heap with the lowest (partial cost, sample) on top.
  const auto after = [](const Candidate& a, const Candidate& b) {
    return a.partial > b.partial || (a.partial == b.partial && a.sample > b.sample);
  };
  std::make_heap(candidates.begin(), candidates.end(), after);
  while (!candidates.empty()) {
    std::pop_heap(candidates.begin(), candidates.end(), after);
    const Candidate next = candidates.back();
    candidates.pop_back();
    if (best_cost >= 0.0 && next.partial > best_cost) break;
    double cost = next.partial;
    if (config_.occdist_scale != 0.0) {
      generateTrajectory(pose, samples[next.sample], rollout_, yaw_cache_[next.sample % n_theta]);
      const double obstacle = obstacleCost(rollout_);
      if (obstacle < 0.0) {
        discarded(obstacle);
        continue;
      }
      cost += obstacle * config_.occdist_scale;
    }
    if (best_cost < 0.0 || cost < best_cost || (cost == best_cost && next.sample < best_sample)) {
      best_cost = cost;
      best_sample = next.sample;
    }
  }
  Trajectory best;
  best.cost = -7.0;
  if (best_cost >= 0.0) {
    generateTrajectory(pose, samples[best_sample], best, yaw_cache_[best_sample % n_theta]);
    best.cost = best_cost;
  } else if (oscillation_.restricted()) {
    // Nothing the restriction allows is valid (e.g. only backward, with an obstacle behind).
    // dwa_local_planner drops the restriction with move_base's next re-plan (setPlan resets the
    // flags); this planner keeps it across re-plans of one route, so it drops it here, where it
    // would otherwise hold the robot still until the goal is aborted.
    resetOscillationFlags();
  }
  updateOscillationFlags(pose, best);
  return best;
}

const char* DwaPlanner::discardReason(size_t code) {
  // By the codes the critics return above: -2 / -3 (path grid), -4 (map), -5 (oscillation),
  // -6 / -7 (footprint).
  static const char* const kReasons[8] = {"", "", "unreachable from the path", "on an obstacle of the path's grid",
                                          "off the local map", "oscillation", "footprint on a lethal cell",
                                          "centre off the map"};
  return code < 8 ? kReasons[code] : "";
}

bool DwaPlanner::checkTrajectory(const Pose2D& pose, const Velocity2D& /*velocity*/, const Velocity2D& sample) {
  resetOscillationFlags();
  Trajectory trajectory;
  // A sample that generates no rollout (e.g. a full stop) has nothing to collide with.
  generateTrajectory(pose, sample, trajectory);
  return scoreTrajectory(trajectory, -1.0) >= 0.0;
}

}  // namespace nav
}  // namespace marl_mrta
