// The particle filter's one source of randomness: a seeded std::mt19937_64 (its output sequence
// is fixed by the C++ standard) turned into uniform and Gaussian draws here rather than by the
// std:: distributions, whose algorithms differ between standard libraries. The same seed and the
// same calls give the same numbers bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>

namespace marl_mrta {
namespace loc {

class RandomSource {
 public:
  explicit RandomSource(uint64_t seed = 0) : engine_(seed) {}
  void reseed(uint64_t seed) { engine_.seed(seed); }

  // Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform in [0, n), n > 0.
  size_t index(size_t n);
  // Zero-mean normal with standard deviation `sigma` (Marsaglia's polar method, as amcl's
  // pf_ran_gaussian).
  double gaussian(double sigma);

 private:
  std::mt19937_64 engine_;
};

}  // namespace loc
}  // namespace marl_mrta
