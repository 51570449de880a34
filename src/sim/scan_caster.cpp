#include "marl_mrta/sim/scan_caster.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "marl_mrta/sim/obstacle_grid.h"

namespace marl_mrta {
namespace sim {

namespace {

constexpr int kTile = 16;  // cells per tile side
constexpr double kTwoPi = 2.0 * M_PI;

// atan2 to about 1e-8 rad (Abramowitz & Stegun 4.4.49); only used to pick the beams a
// segment may cover, which are then tested exactly.
double fastAtan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  const double big = std::max(ax, ay);
  if (big == 0.0) return 0.0;
  const double z = std::min(ax, ay) / big;
  const double z2 = z * z;
  double r = z * (1.0 + z2 * (-0.3333314528 + z2 * (0.1999355085 + z2 * (-0.1420889944 + z2 * (0.1065626393 +
             z2 * (-0.0752896400 + z2 * (0.0429096138 + z2 * (-0.0161657367 + z2 * 0.0028662257))))))));
  if (ay > ax) r = M_PI_2 - r;
  if (x < 0.0) r = M_PI - r;
  return y < 0.0 ? -r : r;
}

double wrapPositive(double angle) {
  angle = std::fmod(angle, kTwoPi);
  return angle < 0.0 ? angle + kTwoPi : angle;
}

}  // namespace

ScanCaster::ScanCaster(const map::OccupancyMap& map)
    : width_(map.width),
      height_(map.height),
      resolution_(map.resolution),
      origin_x_(map.origin_x),
      origin_y_(map.origin_y),
      origin_yaw_(map.origin_yaw) {
  occupied_.resize(map.data.size());
  for (size_t i = 0; i < map.data.size(); ++i) {
    occupied_[i] = isObstacle(map.data[i]);
  }
  auto occupied = [&](int cx, int cy) {
    return cx >= 0 && cy >= 0 && cx < width_ && cy < height_ && occupied_[static_cast<size_t>(cy) * width_ + cx];
  };
  tiles_x_ = (width_ + kTile - 1) / kTile;
  tiles_y_ = (height_ + kTile - 1) / kTile;
  tile_segments_.resize(static_cast<size_t>(tiles_x_) * tiles_y_);

  // Borders between an occupied and a free cell, merged into maximal runs with the same facing.
  for (int vertical = 1; vertical >= 0; --vertical) {
    const int lines = vertical ? width_ : height_;      // border lines 0..lines
    const int length = vertical ? height_ : width_;     // cells along a line
    for (int line = 0; line <= lines; ++line) {
      int run_start = -1;
      bool run_seen_from_low = false;
      for (int along = 0; along <= length; ++along) {
        int state = 0;  // 0 no border, 1 seen from below `line`, 2 seen from above
        if (along < length) {
          const bool below = vertical ? occupied(line - 1, along) : occupied(along, line - 1);
          const bool above = vertical ? occupied(line, along) : occupied(along, line);
          if (below != above) state = above ? 1 : 2;
        }
        const bool continues = run_start >= 0 && state != 0 && (state == 1) == run_seen_from_low;
        if (run_start >= 0 && !continues) {
          addSegment({double(line), double(run_start), double(along), vertical == 1, run_seen_from_low});
          run_start = -1;
        }
        if (state != 0 && run_start < 0) {
          run_start = along;
          run_seen_from_low = state == 1;
        }
      }
    }
  }
  visited_stamp_.assign(segments_.size(), 0);
}

void ScanCaster::addSegment(const Segment& segment) {
  const auto index = static_cast<uint32_t>(segments_.size());
  segments_.push_back(segment);
  const double x0 = segment.vertical ? segment.fixed : segment.low;
  const double x1 = segment.vertical ? segment.fixed : segment.high;
  const double y0 = segment.vertical ? segment.low : segment.fixed;
  const double y1 = segment.vertical ? segment.high : segment.fixed;
  auto tileOf = [](double coordinate, int tiles) {
    return std::min(std::max(static_cast<int>(coordinate) / kTile, 0), tiles - 1);
  };
  // Borders on a tile edge go to the tiles on both sides.
  for (int ty = tileOf(y0 - 0.5, tiles_y_); ty <= tileOf(y1 + 0.5, tiles_y_); ++ty) {
    for (int tx = tileOf(x0 - 0.5, tiles_x_); tx <= tileOf(x1 + 0.5, tiles_x_); ++tx) {
      tile_segments_[static_cast<size_t>(ty) * tiles_x_ + tx].push_back(index);
    }
  }
}

void ScanCaster::cast(const Pose2D& sensor, const BeamFan& beams, double max_range, float* ranges) const {
  const int n = beams.count;
  // The sensor in grid units.
  const double c = std::cos(origin_yaw_), s = std::sin(origin_yaw_);
  const double wx = sensor.x - origin_x_, wy = sensor.y - origin_y_;
  const double sx = (c * wx + s * wy) / resolution_;
  const double sy = (-s * wx + c * wy) / resolution_;
  const double reach = max_range / resolution_;
  const double first_angle = sensor.yaw - origin_yaw_ + beams.angle_min;

  const int cx = static_cast<int>(std::floor(sx)), cy = static_cast<int>(std::floor(sy));
  if (cx >= 0 && cy >= 0 && cx < width_ && cy < height_ && occupied_[static_cast<size_t>(cy) * width_ + cx]) {
    std::fill(ranges, ranges + n, 0.0f);  // the sensor is inside an obstacle
    return;
  }

  dir_x_.resize(n);
  dir_y_.resize(n);
  inv_x_.resize(n);
  inv_y_.resize(n);
  const double first_c = std::cos(first_angle), first_s = std::sin(first_angle);
  const double step_c = std::cos(beams.increment), step_s = std::sin(beams.increment);
  double beam_c = first_c, beam_s = first_s;
  for (int i = 0; i < n; ++i) {
    if (i % 64 == 0) {  // re-anchor the rotation recurrence against rounding drift
      beam_c = std::cos(first_angle + i * beams.increment);
      beam_s = std::sin(first_angle + i * beams.increment);
    }
    dir_x_[i] = beam_c;
    dir_y_[i] = beam_s;
    const double next_c = beam_c * step_c - beam_s * step_s;
    beam_s = beam_s * step_c + beam_c * step_s;
    beam_c = next_c;
  }
  for (int i = 0; i < n; ++i) inv_x_[i] = 1.0 / dir_x_[i];  // separate loops: these vectorise
  for (int i = 0; i < n; ++i) inv_y_[i] = 1.0 / dir_y_[i];
  std::fill(ranges, ranges + n, std::numeric_limits<float>::infinity());
  const bool full_turn = n * beams.increment >= kTwoPi - 1e-9;

  if (++stamp_ == 0) {
    std::fill(visited_stamp_.begin(), visited_stamp_.end(), 0);
    stamp_ = 1;
  }
  const int tx0 = std::max(static_cast<int>(std::floor((sx - reach) / kTile)), 0);
  const int tx1 = std::min(static_cast<int>(std::floor((sx + reach) / kTile)), tiles_x_ - 1);
  const int ty0 = std::max(static_cast<int>(std::floor((sy - reach) / kTile)), 0);
  const int ty1 = std::min(static_cast<int>(std::floor((sy + reach) / kTile)), tiles_y_ - 1);
  for (int ty = ty0; ty <= ty1; ++ty) {
    for (int tx = tx0; tx <= tx1; ++tx) {
      for (uint32_t index : tile_segments_[static_cast<size_t>(ty) * tiles_x_ + tx]) {
        if (visited_stamp_[index] == stamp_) continue;
        visited_stamp_[index] = stamp_;
        const Segment& seg = segments_[index];
        // Along the segment's normal axis ("across") and its own axis ("along").
        const double across = seg.vertical ? sx : sy;
        const double along = seg.vertical ? sy : sx;
        const double gap = seg.fixed - across;
        if (seg.seen_from_low ? gap <= 0.0 : gap >= 0.0) continue;  // its back, or edge-on
        const double nearest_along = std::min(std::max(along, seg.low), seg.high);
        if (gap * gap + (nearest_along - along) * (nearest_along - along) > reach * reach) continue;

        // Beams between the directions to the two ends (less than half a turn apart).
        const double ax = seg.vertical ? gap : seg.low - sx, ay = seg.vertical ? seg.low - sy : gap;
        const double bx = seg.vertical ? gap : seg.high - sx, by = seg.vertical ? seg.high - sy : gap;
        const double angle_a = wrapPositive(fastAtan2(ay, ax) - first_angle);
        const double angle_b = wrapPositive(fastAtan2(by, bx) - first_angle);
        double start = angle_a, span = wrapPositive(angle_b - angle_a);
        if (span > M_PI) {
          start = angle_b;
          span = kTwoPi - span;
        }
        const double* dir_along = seg.vertical ? dir_y_.data() : dir_x_.data();
        const double* inv_across = seg.vertical ? inv_x_.data() : inv_y_.data();
        auto test_beam = [&](int i) {
          const double t = gap * inv_across[i];
          if (!(t > 0.0) || t > reach || !(t < ranges[i])) return;  // also rejects NaN / inf
          const double hit = along + t * dir_along[i];
          if (hit < seg.low || hit > seg.high) return;
          ranges[i] = static_cast<float>(t);
        };
        // One beam of margin on each side covers the rounding of the angles.
        auto sweep = [&](double from, double to) {
          int k = static_cast<int>(std::floor(from / beams.increment)) - 1;
          int k_end = static_cast<int>(std::ceil(to / beams.increment)) + 1;
          if (full_turn) {
            if (k_end - k + 1 > n) k_end = k + n - 1;
            int i = ((k % n) + n) % n;
            for (; k <= k_end; ++k) {
              test_beam(i);
              if (++i == n) i = 0;
            }
          } else {
            for (k = std::max(k, 0); k <= std::min(k_end, n - 1); ++k) test_beam(k);
          }
        };
        sweep(start, start + span);
        if (!full_turn && start + span > kTwoPi) sweep(start - kTwoPi, start + span - kTwoPi);
      }
    }
  }
  // Grid units to metres.
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(ranges[i])) ranges[i] = static_cast<float>(ranges[i] * resolution_);
  }
}

}  // namespace sim
}  // namespace marl_mrta
