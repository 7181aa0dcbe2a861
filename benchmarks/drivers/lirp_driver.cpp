// Calls poseonly::lirp() on seeded synthetic problems (n points, optional bearing noise in radians):
// the program benchmarks/core_instructions.py runs under callgrind (instruction counts do not depend
// on the machine's load) and times.
//   lirp_driver N CALLS NOISE ALL_COSTS
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "lirp.h"

using namespace poseonly;

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 30, calls = argc > 2 ? std::atoi(argv[2]) : 2000;
  const double noise = argc > 3 ? std::atof(argv[3]) : 0.0;
  const bool all_costs = argc > 4 && std::atoi(argv[4]) != 0;
  constexpr int kScenes = 50;
  std::mt19937_64 rng(1);
  std::normal_distribution<double> N(0.0, 1.0);
  std::vector<std::vector<double>> F1(kScenes), F2(kScenes);
  for (int s = 0; s < kScenes; ++s) {
    const Vec3 axis = Vec3(N(rng), N(rng), N(rng)).normalized();
    const Mat3 R = Eigen::AngleAxisd(0.2, axis).toRotationMatrix();
    const Vec3 t = Vec3(N(rng), N(rng), N(rng)).normalized();
    for (int i = 0; i < n; ++i) {
      const Vec3 X(N(rng), N(rng), 5.0 + 0.6 * N(rng));  // about +-20 deg of field of view, depth 5 +- 0.6
      const Vec3 a = (X.normalized() + noise * Vec3(N(rng), N(rng), N(rng))).normalized();
      const Vec3 b = ((R * X + t).normalized() + noise * Vec3(N(rng), N(rng), N(rng))).normalized();
      for (int k = 0; k < 3; ++k) F1[s].push_back(a(k)), F2[s].push_back(b(k));
    }
  }
  LirpResult r;
  double acc = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < calls; ++k) {
    const int s = k % kScenes;
    lirp(Points{F1[s].data(), F2[s].data(), n}, nullptr, all_costs, &r);
    acc += r.id[r.best].cost;
  }
  const auto t1 = std::chrono::steady_clock::now();
  std::printf("%.3f us per call (checksum %.6g)\n", std::chrono::duration<double, std::micro>(t1 - t0).count() / calls, acc);
  return 0;
}
