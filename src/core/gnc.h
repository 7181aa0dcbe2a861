// GNC-IRLS (Algorithm 2) with Peng et al.'s MS-TLS weights or Yang et al.'s classic GNC-TLS, on
// weighted LiRP. numpy reference: tests/reference/gnc.py (the loop as written, no cycle exit).
#pragma once

#include <functional>

#include "common.h"
#include "residuals.h"

namespace poseonly {

constexpr double kMadToSigma = 1.4826;
constexpr double kMuCap = 1e16;

enum class Schedule : int { MsTls = 0, GncTls = 1 };
enum class Scale : int { Median = 0, Mad = 1, Fixed = 2 };

struct GncOptions {
  Schedule schedule = Schedule::MsTls;
  Scale scale = Scale::Median;
  double scale_value = 0.0;   // sigma when scale == Fixed
  double c_factor = 5.54;     // c = c_factor * sigma
  double noise_bound = 0.0;   // > 0: fixed c (overrides scale and c_factor)
  int max_iterations = 100;
  double eps0 = 1e-9;         // relative: |d eps| <= eps0 * max(|eps|, tiny)
  double sigma_floor = 1e-12;
  double mu_factor = 1.4;
  double mu0 = 0.0;           // > 0: initial mu; else Peng's (MS) or Yang's (classic) rule
  Residual residual = Residual::LiGT;
  bool all_candidates = false;  // choose among LiRP's valid candidates by sum w v (else PPO's best)
  int min_sample = 6;           // weights leaving fewer non-zero points stop the problem
  int cycle_period = 8;         // 0: no limit-cycle exit
  // called before every iteration after the first: true ends the problem with the last iteration's
  // outputs (GncResult::interrupted; Ctrl-C from Python's main thread, bind_lirp.cpp)
  std::function<bool()> interrupted;
};

struct GncResult {
  Pose pose;
  std::vector<double> weights;    // the final weights (the next iteration's input)
  std::vector<double> residuals;  // of the returned pose (inf where not finite)
  double c = 0.0;                 // the final noise bound
  int iterations = 0;
  bool converged = false;
  bool interrupted = false;  // GncOptions::interrupted ended it
};

// TLS weight of one residual for bound c and control parameter mu.
double tls_weight(double v, double c, double mu, Schedule schedule);

// Algorithm 2 from initial weights w0 (nullptr: ones).
void gnc_irls(const Points& P, const double* w0, const GncOptions& opt, GncResult* out);

}  // namespace poseonly
