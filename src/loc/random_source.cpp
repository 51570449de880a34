#include "marl_mrta/loc/random_source.h"

#include <cmath>

namespace marl_mrta {
namespace loc {

size_t RandomSource::index(size_t n) {
  const size_t i = static_cast<size_t>(uniform() * static_cast<double>(n));
  return i < n ? i : n - 1;  // uniform() * n can round up to n for very large n
}

double RandomSource::gaussian(double sigma) {
  double x1, x2, w;
  do {
    x1 = 2.0 * uniform() - 1.0;
    x2 = 2.0 * uniform() - 1.0;
    w = x1 * x1 + x2 * x2;
  } while (w >= 1.0 || w == 0.0);
  return sigma * x2 * std::sqrt(-2.0 * std::log(w) / w);
}

}  // namespace loc
}  // namespace marl_mrta
