#pragma once
// Deterministic random numbers: the same seed gives the same stream on every
// platform and standard library (std::normal_distribution does not promise that),
// so simulated datasets are byte-identical for a given --seed.
#include <cmath>
#include <cstdint>

namespace flatscan {

class Random {
 public:
  explicit Random(uint64_t seed) : state_(seed) {}

  // SplitMix64 (Steele, Lea, Flood 2014): full-period 64-bit generator.
  uint64_t NextU64() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(NextU64() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Standard normal by Box-Muller (the second value is cached).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = 0.0;
    while (u1 <= 0.0) u1 = Uniform();
    const double u2 = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }
  // A child stream whose seed depends only on this stream's seed and `index`.
  static uint64_t DeriveSeed(uint64_t seed, uint64_t index) {
    Random r(seed ^ (0xD1B54A32D192ED03ull * (index + 1)));
    return r.NextU64();
  }

 private:
  uint64_t state_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace flatscan
