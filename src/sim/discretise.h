// Private helper shared by the models with an exact linear part (dc_servo, rigid_load).
#pragma once

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

namespace blmd::internal {

// Exact zero-order-hold discretisation: x+ = Ad x + Bd [inputs], from expm([[A,B],[0,0]] dt).
template <int N, int M>
void Discretise(const Eigen::Matrix<double, N, N>& A, const Eigen::Matrix<double, N, M>& B,
                double dt, Eigen::Matrix<double, N, N>* Ad, Eigen::Matrix<double, N, M>* Bd) {
  Eigen::Matrix<double, N + M, N + M> augmented = Eigen::Matrix<double, N + M, N + M>::Zero();
  augmented.template topLeftCorner<N, N>() = A * dt;
  augmented.template topRightCorner<N, M>() = B * dt;
  const Eigen::Matrix<double, N + M, N + M> expm = augmented.exp();
  *Ad = expm.template topLeftCorner<N, N>();
  *Bd = expm.template topRightCorner<N, M>();
}

}  // namespace blmd::internal
