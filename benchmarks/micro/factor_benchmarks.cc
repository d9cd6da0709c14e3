// Linearising one built-in factor as the solver does: Evaluate, then whiten the residual and
// every Jacobian block.
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"

namespace tether {
namespace {

SqrtInformation Noise(int dim) {
  Eigen::MatrixXd omega = Eigen::MatrixXd::Identity(dim, dim) * 4.0;
  for (int i = 0; i + 1 < dim; ++i) omega(i, i + 1) = omega(i + 1, i) = 0.5;  // a full R
  return SqrtInformation::FromInformation(omega);
}

void LinearizeLoop(benchmark::State& state, const Factor& f, const std::vector<std::vector<double>>& params) {
  std::vector<const double*> p;
  for (const auto& v : params) p.push_back(v.data());
  const std::vector<VarType> types = f.variable_types();
  std::vector<std::vector<double>> jac(types.size());
  std::vector<double*> jp;
  std::vector<int> cols;
  for (std::size_t k = 0; k < types.size(); ++k) {
    cols.push_back(TangentDim(types[k]));
    jac[k].assign(f.dim() * cols[k], 0.0);
    jp.push_back(jac[k].data());
  }
  double r[kInlineResidualDim];
  for (auto _ : state) {
    f.Evaluate(p.data(), r, jp.data());
    f.noise().WhitenVector(r);
    for (std::size_t k = 0; k < jp.size(); ++k) f.noise().WhitenRowMajor(jp[k], cols[k]);
    benchmark::DoNotOptimize(r);
    benchmark::DoNotOptimize(jp[0][0]);
    benchmark::ClobberMemory();
  }
}

const std::vector<double> kSE2a = {1.0, 2.0, 0.3}, kSE2b = {2.1, 2.9, 0.45};
const std::vector<double> kSE3a = {1.0, 2.0, 3.0, 0.1, 0.2, 0.3, 0.927362},
                          kSE3b = {1.5, 2.2, 3.1, 0.12, 0.18, 0.33, 0.918};

void BM_LinearizeBetweenSE2(benchmark::State& state) {
  const BetweenSE2 f(0, 1, SE2d(1.0, 1.0, 0.1), Noise(3));
  LinearizeLoop(state, f, {kSE2a, kSE2b});
}
BENCHMARK(BM_LinearizeBetweenSE2);

void BM_LinearizeBetweenSE3(benchmark::State& state) {
  const BetweenSE3 f(0, 1, SE3d::FromParams(kSE3b.data()), Noise(6));
  LinearizeLoop(state, f, {kSE3a, kSE3b});
}
BENCHMARK(BM_LinearizeBetweenSE3);

void BM_LinearizePosePoint2(benchmark::State& state) {
  const PosePoint2 f(0, 1, Eigen::Vector2d(1.0, 0.5), Noise(2));
  LinearizeLoop(state, f, {kSE2a, {2.0, 2.4}});
}
BENCHMARK(BM_LinearizePosePoint2);

void BM_LinearizePosePoint3(benchmark::State& state) {
  const PosePoint3 f(0, 1, Eigen::Vector3d(1.0, 0.5, -0.2), Noise(3));
  LinearizeLoop(state, f, {kSE3a, {2.0, 2.4, 2.9}});
}
BENCHMARK(BM_LinearizePosePoint3);

void BM_LinearizePriorSE2(benchmark::State& state) {
  const PriorSE2 f(0, SE2d(1.1, 1.9, 0.25), Noise(3));
  LinearizeLoop(state, f, {kSE2a});
}
BENCHMARK(BM_LinearizePriorSE2);

void BM_LinearizePriorSE3(benchmark::State& state) {
  const PriorSE3 f(0, SE3d::FromParams(kSE3b.data()), Noise(6));
  LinearizeLoop(state, f, {kSE3a});
}
BENCHMARK(BM_LinearizePriorSE3);

}  // namespace
}  // namespace tether
