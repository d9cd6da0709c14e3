#include "tether/solvers/covariance.h"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <unordered_map>

#include "covariance_factor.h"
#include "gauge.h"
#include "minimizer.h"
#include "problem.h"
#include "tether/core/output_file.h"
#include "tether/core/registry.h"
#include "tether/core/timing.h"

namespace tether {

bool CovarianceOptions::IsValid(std::string* why) const {
  std::string w;
  if (linear_solver != "cholmod" && linear_solver != "ldlt" && linear_solver != "qr") {
    w = "linear_solver is '" + linear_solver + "'; use cholmod, ldlt or qr";
  } else if (num_threads < 1) {
    w = "num_threads is " + std::to_string(num_threads) + "; use 1 or more";
  }
  if (why) *why = w;
  return w.empty();
}

struct Marginals::Impl {
  Values values;
  std::set<Key> fixed;
  std::set<Key> known;  // every key of the values
  SolverSummary gauge;  // gauge_fixed_automatically and gauge_key, from ChooseFixed
  std::vector<Key> free_keys;
  std::unordered_map<Key, int> index;  // key -> free variable
  std::vector<int> offsets, dims;
  std::vector<VarType> types;
  std::unique_ptr<internal::CovarianceFactor> factor;
  double linearize_seconds = 0;

  // The free variable of `key`, or InvalidArgument saying why it has no covariance.
  int Find(Key key) const {
    const auto it = index.find(key);
    if (it != index.end()) return it->second;
    const std::string k = "variable " + std::to_string(key);
    if (!values.Has(key)) throw InvalidArgument(k + " is not in the values; ask for one of the graph's variables");
    if (gauge.gauge_fixed_automatically && key == gauge.gauge_key) {
      throw InvalidArgument(k +
                            " is held fixed to remove the gauge freedom (nothing was fixed and no prior anchors the "
                            "graph), so it has no covariance: the others are relative to it. Fix another variable "
                            "or add a prior to get its covariance");
    }
    if (fixed.count(key)) throw InvalidArgument(k + " is held fixed in the graph, so it has no covariance");
    throw InvalidArgument(k + " is used by no factor, so its covariance is undetermined");
  }
};

Marginals::Marginals(const FactorGraph& graph, const Values& values, const CovarianceOptions& options)
    : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("invalid covariance options: " + why);
  Impl& m = *impl_;
  const internal::Clock::time_point t0 = internal::Clock::now();
  m.values = values;
  m.fixed = internal::ChooseFixed(graph, m.values, &m.gauge);
  internal::Problem p(graph, &m.values, m.fixed, options.num_threads);
  const double chi2 = p.Linearize();
  if (!std::isfinite(chi2) || !p.jacobian_finite()) {
    std::string where = p.DescribeNonFinite();
    throw InvalidArgument("cannot compute covariances: the linearisation is not finite" +
                          (where.empty() ? std::string() : ": " + where) + "; check the values and measurements");
  }
  const std::vector<int> sizes = p.BlockSizes();
  for (int i = 0; i < p.num_free(); ++i) {
    m.index.emplace(p.free_key(i), i);
    m.free_keys.push_back(p.free_key(i));
    m.offsets.push_back(p.free_offset(i));
    m.dims.push_back(sizes[i]);
    m.types.push_back(p.free_type(i));
  }
  if (p.tangent_dim() == 0) {
    m.linearize_seconds = SecondsSince(t0);
    return;
  }
  const internal::ColumnNamer name = [&m](int column) {
    int v = 0;
    while (v + 1 < static_cast<int>(m.offsets.size()) && m.offsets[v + 1] <= column) ++v;
    return "variable " + std::to_string(m.free_keys[v]) + " (" + std::string(ToString(m.types[v])) +
           "), tangent coordinate " + std::to_string(column - m.offsets[v]);
  };
  internal::Csc a;
  std::vector<int> positions;
  if (options.linear_solver == "qr") {
    p.BuildJacobianStructure(&a, &positions);
    std::vector<double> rhs(static_cast<std::size_t>(a.rows));
    p.AssembleJacobian(&a, rhs.data());
    m.linearize_seconds = SecondsSince(t0);
    m.factor = internal::MakeQrCovariance(a, name);
  } else {
    p.BuildNormalStructure(&a, &positions);
    std::vector<double> g(static_cast<std::size_t>(p.tangent_dim()));
    p.AssembleNormal(&a, g.data());
    m.linearize_seconds = SecondsSince(t0);
    m.factor = options.linear_solver == "cholmod" ? internal::MakeCholmodCovariance(a, name)
                                                  : internal::MakeLdltCovariance(a, name);
  }
}

Marginals::~Marginals() = default;

Eigen::MatrixXd Marginals::Marginal(Key key) const { return MarginalsOf({key})[0]; }

std::vector<Eigen::MatrixXd> Marginals::MarginalsOf(const std::vector<Key>& keys) const {
  std::vector<int> offsets, dims;
  for (Key k : keys) {
    const int v = impl_->Find(k);
    offsets.push_back(impl_->offsets[v]);
    dims.push_back(impl_->dims[v]);
  }
  if (keys.empty()) return {};
  // One variable: its columns solved directly; many: the factor's batch method.
  if (keys.size() == 1) return {JointMarginal(keys)};
  return impl_->factor->DiagonalBlocks(offsets, dims);
}

Eigen::MatrixXd Marginals::JointMarginal(const std::vector<Key>& keys) const {
  std::vector<int> vars;
  int k = 0;
  for (Key key : keys) {
    vars.push_back(impl_->Find(key));
    k += impl_->dims[vars.back()];
  }
  for (std::size_t i = 0; i < vars.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (vars[i] == vars[j]) {
        throw InvalidArgument("JointMarginal: variable " + std::to_string(keys[i]) +
                              " is listed twice; list each once");
      }
    }
  }
  if (vars.empty()) return Eigen::MatrixXd();
  Eigen::MatrixXd b = Eigen::MatrixXd::Zero(impl_->factor->n(), k);
  for (std::size_t v = 0, c = 0; v < vars.size(); c += impl_->dims[vars[v]], ++v) {
    for (int i = 0; i < impl_->dims[vars[v]]; ++i) b(impl_->offsets[vars[v]] + i, static_cast<Eigen::Index>(c) + i) = 1;
  }
  const Eigen::MatrixXd x = impl_->factor->Solve(b);
  Eigen::MatrixXd out(k, k);
  for (std::size_t v = 0, r = 0; v < vars.size(); r += impl_->dims[vars[v]], ++v) {
    out.middleRows(static_cast<Eigen::Index>(r), impl_->dims[vars[v]]) =
        x.middleRows(impl_->offsets[vars[v]], impl_->dims[vars[v]]);
  }
  return 0.5 * (out + out.transpose());
}

const std::vector<Key>& Marginals::free_keys() const { return impl_->free_keys; }
const std::set<Key>& Marginals::fixed_keys() const { return impl_->fixed; }
bool Marginals::gauge_fixed_automatically() const { return impl_->gauge.gauge_fixed_automatically; }
Key Marginals::gauge_key() const { return impl_->gauge.gauge_key; }
double Marginals::factorize_seconds() const { return impl_->factor ? impl_->factor->factorize_seconds() : 0.0; }
double Marginals::linearize_seconds() const { return impl_->linearize_seconds; }
std::string Marginals::Description() const {
  std::string d = impl_->factor ? impl_->factor->Description() : std::string("no free variables");
  if (gauge_fixed_automatically()) d += "; variable " + std::to_string(gauge_key()) + " held fixed (automatic gauge)";
  return d;
}

void WriteCovariances(std::ostream& out, const Values& values, const std::vector<Key>& keys,
                      const std::vector<Eigen::MatrixXd>& covariances) {
  if (keys.size() != covariances.size()) {
    throw InvalidArgument("WriteCovariances: " + std::to_string(keys.size()) + " keys but " +
                          std::to_string(covariances.size()) + " covariances");
  }
  std::string line =
      "# tether marginal covariances in tangent coordinates (box-plus delta): id type n, then the upper "
      "triangle row by row\n";
  for (std::size_t i = 0; i < keys.size(); ++i) {
    const Eigen::MatrixXd& c = covariances[i];
    AppendKey(&line, keys[i]);
    line += ' ' + std::string(ToString(values.TypeOf(keys[i]))) + ' ' + std::to_string(c.rows());
    for (Eigen::Index r = 0; r < c.rows(); ++r) {
      for (Eigen::Index k = r; k < c.cols(); ++k) {
        line.push_back(' ');
        AppendDouble(&line, c(r, k));
      }
    }
    line.push_back('\n');
    out.write(line.data(), static_cast<std::streamsize>(line.size()));
    line.clear();
  }
  out.write(line.data(), static_cast<std::streamsize>(line.size()));
}

void WriteCovarianceFile(const std::string& path, const Values& values, const std::vector<Key>& keys,
                         const std::vector<Eigen::MatrixXd>& covariances) {
  OutputFile file(path, "covariances");
  file.Stage([&](std::ostream& s) { WriteCovariances(s, values, keys, covariances); });
  file.Commit();
}

}  // namespace tether
