// Residual statistics (docs/identification.md, docs/discovery.md).
#pragma once

#include <vector>

namespace blmd {

// Sample autocorrelation r_1..r_max_lag of x (mean removed); empty if x is constant.
std::vector<double> Autocorrelation(const std::vector<double>& x, int max_lag);

struct LjungBox {
  int lags = 0;
  double q = 0.0;        // Q = n (n + 2) sum_k r_k^2 / (n - k)
  double p_value = 1.0;  // P(chi2_lags > Q): small -> not white
};
LjungBox LjungBoxTest(const std::vector<double>& x, int lags);

// Regularised upper incomplete gamma Q(a, x) and the chi-square survival function.
double GammaQ(double a, double x);
double ChiSquareSurvival(double x, double dof);

}  // namespace blmd
