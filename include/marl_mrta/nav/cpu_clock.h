// A std::chrono clock of the calling thread's CPU time: timings on a shared machine then say
// how long the work took, not how long other processes held the cores.
#pragma once

#include <time.h>

#include <chrono>

namespace marl_mrta {
namespace nav {

struct ThreadCpuClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<ThreadCpuClock>;
  static constexpr bool is_steady = true;
  static time_point now() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return time_point(duration(static_cast<rep>(ts.tv_sec) * 1000000000 + ts.tv_nsec));
  }
};

}  // namespace nav
}  // namespace marl_mrta
