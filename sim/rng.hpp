// Deterministic random numbers for the simulator: std::mt19937_64 as the engine (its output is fixed by
// the standard) and distributions written out here, because std:: distributions differ between
// library versions and the simulator must give byte-identical data sets for a seed on any machine.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace teamscan::sim {

// SplitMix64 step: derives independent stream seeds from (scenario seed, robot id, purpose).
[[nodiscard]] constexpr std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// What a random stream is used for; each robot has one stream per purpose so that adding noise to
// one quantity never shifts the random numbers of another.
enum class RngStream : std::uint64_t { range_noise = 1, odometry = 2 };

class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t robot_id, RngStream stream)
      : engine_{splitmix64(splitmix64(seed) ^ splitmix64(robot_id * 0x100 + static_cast<std::uint64_t>(stream)))} {}

  // Uniform in [0, 1) with 53 random bits.
  [[nodiscard]] double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  // Standard normal by the Box–Muller transform (both values used, the second cached).
  [[nodiscard]] double normal() {
    if (have_spare_) {
      have_spare_ = false;
      return spare_;
    }
    double u1 = uniform();
    while (u1 <= 0.0) u1 = uniform();
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * 3.14159265358979323846 * u2;
    spare_ = radius * std::sin(angle);
    have_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool have_spare_ = false;
};

}  // namespace teamscan::sim
