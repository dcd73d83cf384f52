// A two-mass shaft (docs/effects.md, two_mass): a motor and its load joined by a shaft of
// stiffness K and damping c. Its two sides from the totals a rigid fit gives, and the coupled
// rows of a state matrix, which the models, their linear parts and the tuning's sampled loop
// all build from here.
#pragma once

#include <Eigen/Core>
#include <numbers>

namespace blmd {

// From the totals J (kg·m²) and B (N·m·s/rad) and the effect's parameters: Jm = J/(1 + r),
// Jl = J − Jm, K = Jl (2π fa)² (N·m/rad), c = 2 ζ Jl 2π fa (N·m·s/rad), Bl = s B, Bm = B − Bl.
struct TwoMassSides {
  double Jm = 0.0, Jl = 0.0, K = 0.0, c = 0.0, Bm = 0.0, Bl = 0.0;

  static TwoMassSides Of(double J, double B, double ratio, double anti_resonance_hz,
                         double damping_ratio, double load_share) {
    TwoMassSides out;
    const double wa = 2.0 * std::numbers::pi * anti_resonance_hz;
    out.Jm = J / (1.0 + ratio);
    out.Jl = J - out.Jm;
    out.K = out.Jl * wa * wa;
    out.c = 2.0 * damping_ratio * out.Jl * wa;
    out.Bl = load_share * B;
    out.Bm = B - out.Bl;
    return out;
  }

  // Writes the coupled shaft into the state matrix *A, the motor's speed, the load's speed and
  // the twist δ = θm − θl at the indices given (the other entries untouched):
  //   Jm w' = −(Bm + c) w + c w_load − K δ + …,   Jl w_load' = c w − (c + Bl) w_load + K δ,
  //   δ' = w − w_load.
  template <typename Matrix>
  void SetRows(int w, int w_load, int twist, Matrix* A) const {
    (*A)(w, w) = -(Bm + c) / Jm;
    (*A)(w, w_load) = c / Jm;
    (*A)(w, twist) = -K / Jm;
    (*A)(w_load, w) = c / Jl;
    (*A)(w_load, w_load) = -(c + Bl) / Jl;
    (*A)(w_load, twist) = K / Jl;
    (*A)(twist, w) = 1.0;
    (*A)(twist, w_load) = -1.0;
  }

  // The load swinging on a motor held at rest: [w_load, δ]' = HeldLoad() [w_load, δ].
  Eigen::Matrix2d HeldLoad() const {
    Eigen::Matrix2d A;
    A << -(c + Bl) / Jl, K / Jl, -1.0, 0.0;
    return A;
  }
};

}  // namespace blmd
