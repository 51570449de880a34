// Comparing sim times given as seconds in doubles the way ros::Time compares them, in whole
// nanoseconds: a tie (a patience that ends exactly on a tick) must come out the same whatever
// the absolute times, whose rounding in doubles depends on when the run started.
#pragma once

namespace marl_mrta {
namespace nav {

// Whether `now` is later than `since` + `duration` (by at least a nanosecond).
inline bool isPast(double now, double since, double duration) { return now > since + duration + 1e-9; }

}  // namespace nav
}  // namespace marl_mrta
