#include "marl_mrta/nav/navfn_planner.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace marl_mrta {
namespace nav {
namespace {

constexpr float kInvSqrt2 = 0.707106781f;

// splitmix64: a well-mixed hash of (seed, draw, lattice point) -> uniform [0, 1).
double hashUniform(uint64_t seed, uint64_t draw, int64_t i, int64_t j) {
  uint64_t z = seed * 0x9E3779B97F4A7C15ull ^ (draw + 0x632BE59BD9B4E019ull) * 0xBF58476D1CE4E5B9ull ^
               static_cast<uint64_t>(i) * 0x94D049BB133111EBull ^ static_cast<uint64_t>(j) * 0x2545F4914F6CDD1Dull;
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z = z ^ (z >> 31);
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

std::string formatPoint(const Pose2D& p) {
  std::ostringstream out;
  out.precision(2);
  out << std::fixed << "(" << p.x << ", " << p.y << ")";
  return out.str();
}

}  // namespace

NavfnPlanner::NavfnPlanner(const NavfnConfig& config) : config_(config) {}

uint8_t NavfnPlanner::traversalCost(uint8_t costmap_value, bool allow_unknown) {
  if (costmap_value < kInscribedInflated) {
    const int v = kCostNeutral + static_cast<int>(kCostFactor * costmap_value);
    return static_cast<uint8_t>(std::min(v, kCostObstacle - 1));
  }
  if (costmap_value == kNoInformation && allow_unknown) return kCostObstacle - 1;
  return kCostObstacle;
}

void NavfnPlanner::drawVariation() {
  if (config_.path_variability > 0.0) ++variation_draw_;
}

double NavfnPlanner::variationAt(unsigned mx, unsigned my, double resolution) const {
  const double spacing = std::max(1.0, config_.path_variability_length / resolution);
  const double u = mx / spacing, v = my / spacing;
  const int64_t i = static_cast<int64_t>(std::floor(u)), j = static_cast<int64_t>(std::floor(v));
  const double fu = u - i, fv = v - j;
  const uint64_t seed = static_cast<uint64_t>(config_.path_variability_seed);
  const double v00 = hashUniform(seed, variation_draw_, i, j), v10 = hashUniform(seed, variation_draw_, i + 1, j);
  const double v01 = hashUniform(seed, variation_draw_, i, j + 1),
               v11 = hashUniform(seed, variation_draw_, i + 1, j + 1);
  return (1 - fv) * ((1 - fu) * v00 + fu * v10) + fv * ((1 - fu) * v01 + fu * v11);
}

void NavfnPlanner::setupCosts(const CostGrid& costmap, unsigned start_index) {
  nx_ = costmap.sizeX();
  ny_ = costmap.sizeY();
  ns_ = nx_ * ny_;
  cost_.resize(ns_);
  const std::vector<uint8_t>& cells = costmap.cells();
  const bool vary = config_.path_variability > 0.0 && variation_draw_ > 0;
  for (unsigned i = 0; i < ns_; ++i) {
    uint8_t c = traversalCost(i == start_index ? kFreeSpace : cells[i], config_.allow_unknown);
    if (vary && c < kCostObstacle) {
      const double extra = config_.path_variability * kCostNeutral * variationAt(i % nx_, i / nx_, costmap.resolution());
      c = static_cast<uint8_t>(std::min<double>(kCostObstacle - 1, c + extra));
    }
    cost_[i] = c;
  }
  // The outer frame is an obstacle so that neighbour lookups never leave the grid.
  for (unsigned x = 0; x < nx_; ++x) cost_[x] = cost_[(ny_ - 1) * nx_ + x] = kCostObstacle;
  for (unsigned y = 0; y < ny_; ++y) cost_[y * nx_] = cost_[y * nx_ + nx_ - 1] = kCostObstacle;
  potential_.assign(ns_, kPotentialHigh);
  grad_x_.assign(ns_, 0.0f);
  grad_y_.assign(ns_, 0.0f);
  gradients_cached_.clear();
  pending_.assign(ns_, 0);
}

void NavfnPlanner::updateCell(unsigned n) {
  if (cost_[n] >= kCostObstacle) return;  // never propagate into obstacles
  const float l = potential_[n - 1], r = potential_[n + 1], u = potential_[n - nx_], d = potential_[n + nx_];
  float tc = std::min(l, r);
  float ta = std::min(u, d);
  const float hf = cost_[n];
  float dc = tc - ta;
  if (dc < 0) {  // ta is the lowest
    dc = -dc;
    ta = tc;
  }
  float pot;
  if (dc >= hf) {
    pot = ta + hf;  // one-neighbour update
  } else {
    // Two-neighbour planar wave front, navfn's quadratic approximation.
    const float ratio = dc / hf;
    const float v = -0.2301f * ratio * ratio + 0.5307f * ratio + 0.7040f;
    pot = ta + hf * v;
  }
  if (pot >= potential_[n]) return;
  ++expansions_;
  potential_[n] = pot;
  const float le = kInvSqrt2 * cost_[n - 1], re = kInvSqrt2 * cost_[n + 1];
  const float ue = kInvSqrt2 * cost_[n - nx_], de = kInvSqrt2 * cost_[n + nx_];
  std::vector<unsigned>& target = pot < threshold_ ? next_ : overflow_;
  auto push = [&](unsigned m) {
    if (!pending_[m] && cost_[m] < kCostObstacle) {
      target.push_back(m);
      pending_[m] = 1;
    }
  };
  if (l > pot + le) push(n - 1);
  if (r > pot + re) push(n + 1);
  if (u > pot + ue) push(n - nx_);
  if (d > pot + de) push(n + nx_);
}

void NavfnPlanner::startWave(unsigned source) {
  current_.clear();
  next_.clear();
  overflow_.clear();
  threshold_ = kCostObstacle;
  potential_[source] = 0.0f;
  for (long m : {long(source) + 1, long(source) - 1, long(source) - long(nx_), long(source) + long(nx_)}) {
    if (m >= 0 && m < long(ns_) && !pending_[m] && cost_[m] < kCostObstacle) {
      current_.push_back(static_cast<unsigned>(m));
      pending_[m] = 1;
    }
  }
  wave_cycles_left_ = std::max<size_t>(ns_ / 20, nx_ + ny_);
}

bool NavfnPlanner::spreadWave(const std::vector<unsigned>& stop_cells) {
  bool reached = false;
  size_t cycle = 0;
  for (; cycle < wave_cycles_left_ && !reached; ++cycle) {
    if (current_.empty() && next_.empty()) {
      cycle = wave_cycles_left_;
      break;
    }
    for (unsigned n : current_) pending_[n] = 0;
    for (unsigned n : current_) updateCell(n);
    current_.swap(next_);
    next_.clear();
    if (current_.empty()) {  // this priority level is done: take the overflow block
      threshold_ += 2 * kCostNeutral;
      current_.swap(overflow_);
      overflow_.clear();
    }
    for (unsigned cell : stop_cells) reached = reached || potential_[cell] < kPotentialHigh;
  }
  wave_cycles_left_ -= cycle;
  return reached;
}

float NavfnPlanner::gradientAt(unsigned n) {
  if (grad_x_[n] + grad_y_[n] > 0.0f) return 1.0f;  // cached
  if (n < nx_ || n > ns_ - nx_) return 0.0f;
  const float cv = potential_[n];
  float dx = 0.0f, dy = 0.0f;
  if (cv >= kPotentialHigh) {  // in an obstacle: point out of it
    if (potential_[n - 1] < kPotentialHigh) dx = -kCostObstacle;
    else if (potential_[n + 1] < kPotentialHigh) dx = kCostObstacle;
    if (potential_[n - nx_] < kPotentialHigh) dy = -kCostObstacle;
    else if (potential_[n + nx_] < kPotentialHigh) dy = kCostObstacle;
  } else {
    if (potential_[n - 1] < kPotentialHigh) dx += potential_[n - 1] - cv;
    if (potential_[n + 1] < kPotentialHigh) dx += cv - potential_[n + 1];
    if (potential_[n - nx_] < kPotentialHigh) dy += potential_[n - nx_] - cv;
    if (potential_[n + nx_] < kPotentialHigh) dy += cv - potential_[n + nx_];
  }
  const float norm = std::hypot(dx, dy);
  if (norm > 0.0f) {
    grad_x_[n] = dx / norm;
    grad_y_[n] = dy / norm;
    gradients_cached_.push_back(n);
  }
  return norm;
}

bool NavfnPlanner::tracePath(unsigned from, unsigned to, std::vector<float>& path_x, std::vector<float>& path_y) {
  constexpr float kPathStep = 0.5f;  // [cells]
  // Gradients cached by an earlier trace belong to an earlier potential (makePlans traces while
  // the wave goes on).
  for (unsigned n : gradients_cached_) grad_x_[n] = grad_y_[n] = 0.0f;
  gradients_cached_.clear();
  unsigned stc = from;
  float dx = 0.0f, dy = 0.0f;
  const size_t max_steps = std::max<size_t>(ns_ / 2, 4 * nx_);
  for (size_t step = 0; step < max_steps; ++step) {
    const long nearest = std::max(0L, std::min(long(ns_) - 1, long(stc) + long(std::round(dx)) +
                                                                   long(nx_) * long(std::round(dy))));
    if (potential_[nearest] < kCostNeutral) {  // reached the source cell
      path_x.push_back(static_cast<float>(to % nx_));
      path_y.push_back(static_cast<float>(to / nx_));
      return true;
    }
    if (stc < nx_ || stc > ns_ - nx_) return false;  // would leave the grid
    path_x.push_back(stc % nx_ + dx);
    path_y.push_back(stc / nx_ + dy);
    const size_t np = path_x.size();
    // Back where it was two steps ago: the descent is bouncing between two points (navfn
    // tests exact equality, which float noise defeats; a tenth of a cell catches it).
    const bool oscillation = np > 2 && std::fabs(path_x[np - 1] - path_x[np - 3]) < 0.1f &&
                             std::fabs(path_y[np - 1] - path_y[np - 3]) < 0.1f;
    const unsigned up = stc + nx_, down = stc - nx_;
    const bool near_high = potential_[stc] >= kPotentialHigh || potential_[stc + 1] >= kPotentialHigh ||
                           potential_[stc - 1] >= kPotentialHigh || potential_[up] >= kPotentialHigh ||
                           potential_[up + 1] >= kPotentialHigh || potential_[up - 1] >= kPotentialHigh ||
                           potential_[down] >= kPotentialHigh || potential_[down + 1] >= kPotentialHigh ||
                           potential_[down - 1] >= kPotentialHigh;
    if (near_high || oscillation) {
      // Next to an obstacle or going back and forth: step to the lowest of the 8 neighbours.
      unsigned best = stc;
      float best_potential = potential_[stc];
      for (unsigned m : {down - 1, down, down + 1, stc - 1, stc + 1, up - 1, up, up + 1}) {
        if (potential_[m] < best_potential) {
          best_potential = potential_[m];
          best = m;
        }
      }
      stc = best;
      dx = dy = 0.0f;
      if (potential_[stc] >= kPotentialHigh) return false;
    } else {
      // Bilinear interpolation of the gradient of the four cells around the position.
      gradientAt(stc);
      gradientAt(stc + 1);
      gradientAt(up);
      gradientAt(up + 1);
      const float x1 = (1.0f - dx) * grad_x_[stc] + dx * grad_x_[stc + 1];
      const float x2 = (1.0f - dx) * grad_x_[up] + dx * grad_x_[up + 1];
      const float gx = (1.0f - dy) * x1 + dy * x2;
      const float y1 = (1.0f - dx) * grad_y_[stc] + dx * grad_y_[stc + 1];
      const float y2 = (1.0f - dx) * grad_y_[up] + dx * grad_y_[up + 1];
      const float gy = (1.0f - dy) * y1 + dy * y2;
      if (gx == 0.0f && gy == 0.0f) return false;  // flat: no direction to follow
      const float scale = kPathStep / std::hypot(gx, gy);
      dx += gx * scale;
      dy += gy * scale;
      if (dx > 1.0f) { stc++; dx -= 1.0f; }
      if (dx < -1.0f) { stc--; dx += 1.0f; }
      if (dy > 1.0f) { stc += nx_; dy -= 1.0f; }
      if (dy < -1.0f) { stc -= nx_; dy += 1.0f; }
    }
  }
  return false;  // path too long
}

PlanResult NavfnPlanner::makePlan(const CostGrid& costmap, const Pose2D& start, const Pose2D& goal) {
  return makePlan(costmap, start, goal, config_.default_tolerance);
}

PlanResult NavfnPlanner::makePlan(const CostGrid& costmap, const Pose2D& start, const Pose2D& goal,
                                  double tolerance) {
  return std::move(makePlans(costmap, start, {goal}, tolerance).front());
}

std::vector<PlanResult> NavfnPlanner::makePlans(const CostGrid& costmap, const Pose2D& start,
                                                const std::vector<Pose2D>& goals) {
  return makePlans(costmap, start, goals, config_.default_tolerance);
}

std::vector<PlanResult> NavfnPlanner::makePlans(const CostGrid& costmap, const Pose2D& start,
                                                const std::vector<Pose2D>& goals, double tolerance) {
  std::vector<PlanResult> results(goals.size());
  expansions_ = 0;
  unsigned sx, sy;
  if (costmap.sizeX() < 3 || costmap.sizeY() < 3 || !costmap.worldToMap(start.x, start.y, sx, sy)) {
    for (PlanResult& result : results) {
      result.status = PlanResult::Status::kStartOutsideMap;
      result.message = "the robot's position " + formatPoint(start) + " is off the global costmap";
    }
    return results;
  }
  // The wave stops once a goal is reached, unless a tolerance asks for cells around it: the
  // cell whose potential ends the wave for each goal still to plan, -1 for the whole wave.
  struct Waiting {
    size_t goal;
    int stop_at;
  };
  std::vector<Waiting> waiting;
  for (size_t i = 0; i < goals.size(); ++i) {
    unsigned gx, gy;
    const bool goal_inside = costmap.worldToMap(goals[i].x, goals[i].y, gx, gy);
    if (!goal_inside && tolerance <= 0.0) {
      results[i].status = PlanResult::Status::kGoalOutsideMap;
      results[i].message = "the goal " + formatPoint(goals[i]) + " is off the global costmap";
      continue;
    }
    waiting.push_back({i, (goal_inside && tolerance <= 0.0) ? static_cast<int>(costmap.index(gx, gy)) : -1});
  }
  if (waiting.empty()) return results;
  const unsigned start_index = costmap.index(sx, sy);
  setupCosts(costmap, start_index);
  startWave(start_index);
  // Spread until a goal's cell is reached and trace its path then, as makePlan would; a goal
  // that needs the whole wave waits until the wave is over.
  std::vector<unsigned> stop_cells;
  bool wave_on = true;
  while (wave_on && !waiting.empty()) {
    stop_cells.clear();
    for (const Waiting& w : waiting) {
      if (w.stop_at >= 0) stop_cells.push_back(static_cast<unsigned>(w.stop_at));
    }
    wave_on = spreadWave(stop_cells);
    for (size_t k = 0; wave_on && k < waiting.size();) {
      const Waiting& w = waiting[k];
      if (w.stop_at >= 0 && potential_[w.stop_at] < kPotentialHigh) {
        results[w.goal] = finishPlan(costmap, start, start_index, goals[w.goal], tolerance);
        waiting.erase(waiting.begin() + k);
      } else {
        ++k;
      }
    }
  }
  for (const Waiting& w : waiting) results[w.goal] = finishPlan(costmap, start, start_index, goals[w.goal], tolerance);
  return results;
}

PlanResult NavfnPlanner::finishPlan(const CostGrid& costmap, const Pose2D& start, unsigned start_index,
                                    const Pose2D& goal, double tolerance) {
  PlanResult result;
  unsigned gx, gy;
  const bool goal_inside = costmap.worldToMap(goal.x, goal.y, gx, gy);
  // The reachable point closest to the goal within the tolerance square (navfn's search).
  const double res = costmap.resolution();
  bool found = false;
  double best_sq = 1e300;
  Pose2D best = goal;
  for (double y = goal.y - tolerance; y <= goal.y + tolerance + 1e-9; y += res) {
    for (double x = goal.x - tolerance; x <= goal.x + tolerance + 1e-9; x += res) {
      unsigned mx, my;
      if (!costmap.worldToMap(x, y, mx, my)) continue;
      const double sq = (x - goal.x) * (x - goal.x) + (y - goal.y) * (y - goal.y);
      if (potential_[costmap.index(mx, my)] < kPotentialHigh && sq < best_sq) {
        best_sq = sq;
        best = Pose2D{x, y, goal.yaw};
        found = true;
      }
    }
    if (tolerance <= 0.0) break;
  }
  if (!found) {
    if (goal_inside && cost_[costmap.index(gx, gy)] >= kCostObstacle) {
      result.status = PlanResult::Status::kGoalInObstacle;
      std::ostringstream out;
      out << "the goal " << formatPoint(goal) << " is in an obstacle of the global costmap (cost "
          << int(costmap.cost(gx, gy)) << ")";
      result.message = out.str();
    } else {
      result.status = PlanResult::Status::kNoPath;
      result.message = "no path from " + formatPoint(start) + " to " + formatPoint(goal);
    }
    return result;
  }
  unsigned bx, by;
  costmap.worldToMap(best.x, best.y, bx, by);
  std::vector<float> path_x, path_y;
  if (!tracePath(costmap.index(bx, by), start_index, path_x, path_y)) {
    result.status = PlanResult::Status::kNoPath;
    result.message = "no path could be traced down the potential from " + formatPoint(best);
    return result;
  }
  // Traced from the goal: reverse so the path starts at the robot. Cell coordinates are placed as
  // navfn_ros places them (origin + index x resolution, a cell's corner, not its centre): the local
  // planner follows this path, and half a cell decides which side of a wall end it swings.
  for (size_t i = path_x.size(); i-- > 0;) {
    result.path.push_back(Pose2D{costmap.originX() + path_x[i] * res, costmap.originY() + path_y[i] * res, 0.0});
  }
  result.path.push_back(best);
  result.status = PlanResult::Status::kOk;
  return result;
}

}  // namespace nav
}  // namespace marl_mrta
