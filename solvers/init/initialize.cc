#include "tether/solvers/initialize.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include "../src/builtin_linear_solvers.h"
#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/graph_io.h"
#include "tether/core/variable.h"

namespace tether {

namespace {

using Params = std::array<double, 7>;

void CopyParams(const Values& from, Key k, Values* to) {
  const double* p = from.Params(k);
  std::copy(p, p + AmbientDim(from.TypeOf(k)), to->Params(k));
}

// The keys used by the factors of `graph`, each with the type its factors give it.
std::map<Key, VarType> UsedVariables(const FactorGraph& graph) {
  std::map<Key, VarType> used;
  for (const auto& f : graph.factors()) {
    const std::vector<VarType> types = f->variable_types();
    for (std::size_t j = 0; j < f->keys().size() && j < types.size(); ++j) used.emplace(f->keys()[j], types[j]);
  }
  return used;
}

// Union-find over dense indices.
class Components {
 public:
  explicit Components(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0u); }
  std::uint32_t Find(std::uint32_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void Join(std::uint32_t a, std::uint32_t b) {
    a = Find(a), b = Find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);  // the root is the lowest index
  }

 private:
  std::vector<std::uint32_t> parent_;
};

// ---- spanning tree ----

// Composes every used variable outward from one anchor per connected piece: the piece's fixed
// variables if it has any, else its lowest pose key (its lowest key if it has no pose), kept
// at its current value.
void SpanningTree(const FactorGraph& graph, Values* values, InitSummary* s) {
  const std::map<Key, VarType> used = UsedVariables(graph);
  Values seed;
  std::set<Key> anchor_keys;
  for (const std::vector<Key>& piece : ConnectedPieces(*values, graph)) {
    std::vector<Key> anchors;
    for (Key k : piece)
      if (graph.IsFixed(k) && used.count(k)) anchors.push_back(k);
    if (anchors.empty()) {
      // Pieces are sorted, so the first pose is the lowest.
      const auto pose = std::find_if(piece.begin(), piece.end(), [&](Key k) {
        const auto it = used.find(k);
        return it != used.end() && IsPose(it->second);
      });
      if (pose != piece.end()) {
        anchors.push_back(*pose);
      } else if (used.count(piece.front())) {
        anchors.push_back(piece.front());
      }
    }
    // An anchor without a value is left to InitializeSpanningTree: it starts from the origin
    // where nothing has a value, and refuses a variable it cannot reach otherwise.
    for (Key k : anchors) {
      if (!values->Has(k)) continue;
      seed.InsertParams(k, values->TypeOf(k), values->Params(k));
      ++s->anchors;
      anchor_keys.insert(k);
    }
  }
  // Variables of registered types (neither pose nor point: a scale, a bias) keep their values
  // and seed the composition too: the built-in measurements cannot predict them.
  for (const auto& [k, type] : used) {
    if (IsPose(type) || IsPoint(type) || !values->Has(k) || seed.Has(k)) continue;
    seed.InsertParams(k, type, values->Params(k));
    anchor_keys.insert(k);
  }
  InitializeSpanningTree(graph, &seed);  // throws for a variable it cannot reach
  for (const auto& [k, type] : used) {
    if (!values->Has(k)) {
      values->InsertParams(k, type, seed.Params(k));
    } else {
      CopyParams(seed, k, values);
    }
    if (anchor_keys.count(k)) continue;  // kept where it was
    (IsPose(type) ? s->poses_set : s->points_set) += 1;
  }
}

// ---- chordal relaxation ----

template <int D>
struct PoseTraits;

template <>
struct PoseTraits<2> {
  static constexpr VarType kType = VarType::kSE2;
  static constexpr int kRotationDim = 1;
  static void Split(const double* p, Eigen::Matrix2d* R, Eigen::Vector2d* t) {
    *R = Eigen::Rotation2Dd(p[2]).toRotationMatrix();
    *t = Eigen::Vector2d(p[0], p[1]);
  }
  static void Join(const Eigen::Matrix2d& R, const Eigen::Vector2d& t, double* p) {
    p[0] = t.x(), p[1] = t.y(), p[2] = std::atan2(R(1, 0), R(0, 0));
  }
};

template <>
struct PoseTraits<3> {
  static constexpr VarType kType = VarType::kSE3;
  static constexpr int kRotationDim = 3;
  static void Split(const double* p, Eigen::Matrix3d* R, Eigen::Vector3d* t) {
    *R = Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized().toRotationMatrix();
    *t = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  static void Join(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, double* p) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(R).normalized();
    p[0] = t.x(), p[1] = t.y(), p[2] = t.z();
    p[3] = q.x(), p[4] = q.y(), p[5] = q.z(), p[6] = q.w();
  }
};

// The rotation nearest to A in the Frobenius norm.
template <int D>
Eigen::Matrix<double, D, D> NearestRotation(const Eigen::Matrix<double, D, D>& A) {
  using Matrix = Eigen::Matrix<double, D, D>;
  const Eigen::JacobiSVD<Matrix> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix S = Matrix::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(D - 1, D - 1) = -1;
  return svd.matrixU() * S * svd.matrixV().transpose();
}

// Solves sparse symmetric positive-definite systems A X = B that share one sparsity pattern
// (the rotation and the translation systems do) with the solvers' "auto" sparse Cholesky on
// the poses' blocks of `block` unknowns: the ordering and symbolic analysis are done once, the
// block Cholesky factorises where the factor is sparse (the 2D pose graphs), CHOLMOD where it
// is dense, and a matrix that is not positive definite is reported. Throws naming `what` when
// A is singular.
class SpdSolver {
 public:
  /// `linear`: a solver that spans processes (LinearSolverEntry::spans_processes) is used in
  /// place of the default, so that every process of the job takes part and gets the same X.
  SpdSolver(int block, const LinearSolverType& linear) : block_(block) {
    LinearSolverEntry entry;
    if (internal::LinearSolvers().Get(linear.name(), &entry) && entry.spans_processes &&
        entry.form == LinearSystemForm::kNormalEquations) {
      LinearSolverOptions o;
      o.iterative_tolerance = 1e-12;  // an iterative one: a start as good as the factorisation's
      chol_ = entry.make(o);
    }
    if (!chol_) chol_ = internal::MakeAutoCholesky();
  }

  /// A: the upper triangle in compressed columns, diagonal blocks whole (the solver ignores
  /// their lower part), same pattern at every call.
  Eigen::MatrixXd Solve(const internal::Csc& A, const Eigen::MatrixXd& B, const char* what) {
    Eigen::MatrixXd X(B.rows(), B.cols());
    LinearSolverStatus r = LinearSolverStatus::kFailed;
    std::string failure;
    try {
      if (!analysed_) {
        chol_->Analyze(internal::View(A), std::vector<int>(A.cols / block_, block_));
        analysed_ = true;
      }
      r = chol_->Factorize(internal::View(A));
      for (Eigen::Index c = 0; r == LinearSolverStatus::kOk && c < B.cols(); ++c) {
        const Eigen::VectorXd b = B.col(c);
        chol_->Solve(b.data(), X.col(c).data());
      }
    } catch (const Error& e) {
      r = LinearSolverStatus::kFailed;  // the solver itself failed (out of memory, a refused option)
      failure = e.what();
    }
    if (r == LinearSolverStatus::kFailed) {
      throw InvalidArgument(std::string("chordal initialisation: the sparse Cholesky failed on the ") + what +
                            " system (" + (failure.empty() ? std::string("out of memory?") : failure) +
                            "); use --init spanning-tree or --init file");
    }
    if (r != LinearSolverStatus::kOk) {
      throw InvalidArgument(std::string("chordal initialisation: the ") + what +
                            " system is singular (a pose is tied to the others by measurements that fix too "
                            "little of it); use --init spanning-tree or --init file");
    }
    if (!X.allFinite()) {
      throw InvalidArgument(std::string("chordal initialisation: the ") + what + " system gave non-finite values");
    }
    return X;
  }

 private:
  int block_;
  std::unique_ptr<LinearSolver> chol_;
  bool analysed_ = false;
};

template <int D>
class Chordal {
 public:
  using Matrix = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  using Traits = PoseTraits<D>;
  static constexpr int kTangent = D + Traits::kRotationDim;

  Chordal(const FactorGraph& graph, Values* values, const LinearSolverType& linear)
      : graph_(graph), values_(values), spd_(D, linear) {}

  void Run(InitSummary* s) {
    CollectMeasurements();
    if (edges_.empty()) return;
    ChooseAnchors();
    SolveRotations();
    SolveTranslations();
    for (std::uint32_t i = 0; i < keys_.size(); ++i) {
      if (free_[i] < 0) continue;
      Params p;
      Traits::Join(R_[i], t_[i], p.data());
      if (values_->Has(keys_[i])) {
        std::copy(p.begin(), p.begin() + AmbientDim(Traits::kType), values_->Params(keys_[i]));
      } else {
        values_->InsertParams(keys_[i], Traits::kType, p.data());
      }
      ++s->poses_set;
    }
    s->anchors += anchors_;
    s->measurements_used += static_cast<int>(edges_.size());
  }

 private:
  // Pose j as measured from pose i, and how much the measurement says about it.
  struct Edge {
    std::uint32_t i, j;
    Matrix R;              // rotation of j in i's frame
    Vector t;              // position of j in i's frame
    double kappa;          // weight of the chordal term ||R_j - R_i R||^2
    Matrix translation_w;  // information on j's position, in j's frame
  };

  std::uint32_t Node(Key k) {
    const auto [it, inserted] = index_.emplace(k, static_cast<std::uint32_t>(keys_.size()));
    if (inserted) keys_.push_back(k);
    return it->second;
  }

  // Every two-key factor between poses of this dimension whose type can predict one from the
  // other. The measurement is the prediction of the second pose from the first at the origin;
  // its information comes from the factor's whitened Jacobian with respect to the second pose
  // at that point, so it is right for any error definition.
  void CollectMeasurements() {
    edges_.reserve(graph_.size());  // one growth, not a copy at every doubling
    for (const auto& f : graph_.factors()) {
      if (f->keys().size() != 2) continue;
      const std::vector<VarType> types = f->variable_types();
      if (types.size() != 2 || types[0] != Traits::kType || types[1] != Traits::kType) continue;
      Params a, b;
      IdentityParams(Traits::kType, a.data());
      if (!f->Predict(0, a.data(), 1, b.data())) continue;
      if (!std::all_of(b.begin(), b.begin() + AmbientDim(Traits::kType), [](double v) { return std::isfinite(v); }))
        continue;
      if (f->dim() > kInlineResidualDim) continue;  // the pose-pose factors this start reads have at most 6
      std::array<double, kInlineResidualDim> r;
      std::array<double, kInlineResidualDim * kTangent> ja, jb;
      const double* params[2] = {a.data(), b.data()};
      double* jac[2] = {ja.data(), jb.data()};
      if (!f->Linearize(params, r.data(), jac)) continue;
      const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, kTangent, Eigen::RowMajor>> J(jb.data(), f->dim(),
                                                                                                 kTangent);
      const Eigen::Matrix<double, kTangent, kTangent> info = J.transpose() * J;
      if (!info.allFinite()) continue;
      Edge e;
      e.i = Node(f->keys()[0]);
      e.j = Node(f->keys()[1]);
      if (e.i == e.j) continue;
      Traits::Split(b.data(), &e.R, &e.t);
      // ||R_j - R_i R||_F^2 is 2 theta^2 for a small rotation error theta (in 2D and 3D alike), so
      // half the mean angular information weighs it like the factor weighs theta^2.
      e.kappa = info.template bottomRightCorner<Traits::kRotationDim, Traits::kRotationDim>().trace() /
                (2.0 * Traits::kRotationDim);
      e.translation_w = info.template topLeftCorner<D, D>();
      if (!(e.kappa > 0)) continue;
      edges_.push_back(e);
    }
  }

  // Per piece linked by the measurements: its fixed poses, else its lowest key, keep their
  // values; every other pose of the piece is an unknown.
  void ChooseAnchors() {
    const std::uint32_t n = static_cast<std::uint32_t>(keys_.size());
    Components pieces(n);
    for (const Edge& e : edges_) pieces.Join(e.i, e.j);
    std::vector<bool> anchor(n, false), piece_has_fixed(n, false);
    for (std::uint32_t i = 0; i < n; ++i) {
      if (graph_.IsFixed(keys_[i])) anchor[i] = piece_has_fixed[pieces.Find(i)] = true;
    }
    std::vector<std::uint32_t> lowest(n, n);  // per root: the node with the lowest key
    for (std::uint32_t i = 0; i < n; ++i) {
      std::uint32_t& l = lowest[pieces.Find(i)];
      if (l == n || keys_[i] < keys_[l]) l = i;
    }
    for (std::uint32_t root = 0; root < n; ++root) {
      if (lowest[root] != n && !piece_has_fixed[root]) anchor[lowest[root]] = true;
    }
    R_.assign(n, Matrix::Identity());
    t_.assign(n, Vector::Zero());
    free_.assign(n, -1);
    num_free_ = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      if (anchor[i]) {
        ++anchors_;
        if (values_->Has(keys_[i])) Traits::Split(values_->Params(keys_[i]), &R_[i], &t_[i]);
      } else {
        free_[i] = num_free_++;
      }
    }
  }

  // The pattern both systems share, built once: D x D blocks on the diagonal and at (i, j),
  // i < j, for each measurement between two unknowns; the upper triangle in compressed
  // columns, diagonal blocks whole, every block's D columns alike (its rows: the blocks above
  // the diagonal in order, then the diagonal block). rows_[ptr_[j] .. ptr_[j + 1]) are block
  // column j's rows, its own index j last.
  void BuildPattern() {
    std::vector<std::pair<int, int>> pairs;
    pairs.reserve(edges_.size() + num_free_);
    for (const Edge& e : edges_) {
      const int fi = free_[e.i], fj = free_[e.j];
      if (fi >= 0 && fj >= 0) pairs.emplace_back(std::min(fi, fj), std::max(fi, fj));
    }
    for (int j = 0; j < num_free_; ++j) pairs.emplace_back(j, j);
    std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second < b.second : a.first < b.first;
    });
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    ptr_.assign(num_free_ + 1, 0);
    rows_.resize(pairs.size());
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      rows_[k] = pairs[k].first;
      ++ptr_[pairs[k].second + 1];
    }
    for (int j = 0; j < num_free_; ++j) ptr_[j + 1] += ptr_[j];
    a_.rows = a_.cols = D * num_free_;
    a_.colptr.assign(1, 0);
    a_.rowind.clear();
    for (int j = 0; j < num_free_; ++j) {
      for (int c = 0; c < D; ++c) {
        for (int p = ptr_[j]; p < ptr_[j + 1]; ++p) {
          for (int r = 0; r < D; ++r) a_.rowind.push_back(D * rows_[p] + r);
        }
        a_.colptr.push_back(static_cast<int>(a_.rowind.size()));
      }
    }
    a_.values.assign(a_.rowind.size(), 0.0);
  }

  // Adds m to block (fi, fj) of the symmetric system: where fi > fj, m^T to its mirror (fj, fi)
  // in the upper triangle.
  void AddBlock(int fi, int fj, const Matrix& m) {
    const bool mirror = fi > fj;
    const int i = mirror ? fj : fi, j = mirror ? fi : fj;
    const int p =
        static_cast<int>(std::lower_bound(rows_.begin() + ptr_[j], rows_.begin() + ptr_[j + 1], i) - rows_.begin());
    const int row_in_column = (p - ptr_[j]) * D;
    for (int c = 0; c < D; ++c) {
      double* column = a_.values.data() + a_.colptr[D * j + c] + row_in_column;
      for (int r = 0; r < D; ++r) column[r] += mirror ? m(c, r) : m(r, c);
    }
  }

  // With y_i = column c of R_i^T, R_j = R_i R becomes y_j = R^T y_i for each column c: one
  // sparse system with D right-hand sides, unknowns D per free pose.
  void SolveRotations() {
    if (num_free_ == 0) return;
    BuildPattern();
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(D * num_free_, D);
    for (const Edge& e : edges_) {
      const Matrix M = e.R.transpose();  // residual y_j - M y_i
      const int fi = free_[e.i], fj = free_[e.j];
      const Matrix I = Matrix::Identity() * e.kappa;
      if (fi >= 0) AddBlock(fi, fi, I);  // kappa M^T M = kappa I
      if (fj >= 0) AddBlock(fj, fj, I);
      if (fi >= 0 && fj >= 0) {
        AddBlock(fi, fj, -e.kappa * M.transpose());  // block (j, i) is its transpose
      } else if (fj >= 0) {
        rhs.block(D * fj, 0, D, D) += e.kappa * M * R_[e.i].transpose();
      } else if (fi >= 0) {
        rhs.block(D * fi, 0, D, D) += e.kappa * M.transpose() * R_[e.j].transpose();
      }
    }
    const Eigen::MatrixXd Y = spd_.Solve(a_, rhs, "rotation");
    for (std::uint32_t i = 0; i < keys_.size(); ++i) {
      if (free_[i] >= 0) R_[i] = NearestRotation<D>(Y.block(D * free_[i], 0, D, D).transpose());
    }
  }

  // With the rotations held: t_j - t_i = R_i t, weighted by the measurement's information on
  // the position of j, turned into the world frame by R_j.
  void SolveTranslations() {
    if (num_free_ == 0) return;
    std::fill(a_.values.begin(), a_.values.end(), 0.0);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(D * num_free_);
    for (const Edge& e : edges_) {
      const Matrix W = R_[e.j] * e.translation_w * R_[e.j].transpose();
      const Vector c = R_[e.i] * e.t;  // residual t_j - t_i - c
      const int fi = free_[e.i], fj = free_[e.j];
      if (fi >= 0) {
        AddBlock(fi, fi, W);
        rhs.segment<D>(D * fi) -= W * c;
      }
      if (fj >= 0) {
        AddBlock(fj, fj, W);
        rhs.segment<D>(D * fj) += W * c;
      }
      if (fi >= 0 && fj >= 0) {
        AddBlock(fi, fj, -W);  // W is symmetric: block (j, i) is the same
      } else if (fj >= 0) {
        rhs.segment<D>(D * fj) += W * t_[e.i];
      } else if (fi >= 0) {
        rhs.segment<D>(D * fi) += W * t_[e.j];
      }
    }
    const Eigen::VectorXd x = spd_.Solve(a_, rhs, "translation");
    for (std::uint32_t i = 0; i < keys_.size(); ++i) {
      if (free_[i] >= 0) t_[i] = x.segment<D>(D * free_[i]);
    }
  }

  const FactorGraph& graph_;
  Values* values_;
  SpdSolver spd_;    // the rotation and translation systems have the same pattern
  internal::Csc a_;  // the system being assembled (BuildPattern)
  std::vector<int> ptr_, rows_;
  std::unordered_map<Key, std::uint32_t> index_;
  std::vector<Key> keys_;
  std::vector<Edge> edges_;
  std::vector<int> free_;  // index among the unknowns, -1 for anchors
  int num_free_ = 0;
  int anchors_ = 0;
  std::vector<Matrix, Eigen::aligned_allocator<Matrix>> R_;
  std::vector<Vector, Eigen::aligned_allocator<Vector>> t_;
};

// Puts every point that is not fixed at the mean of its predictions from the poses that
// observe it (poses as they are now). Points nothing predicts keep their values.
void PointsFromPoses(const FactorGraph& graph, Values* values, InitSummary* s) {
  struct Sum {
    VarType type;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
  };
  std::map<Key, Sum> points;
  for (const auto& f : graph.factors()) {
    const std::vector<VarType> types = f->variable_types();
    if (f->keys().size() != 2 || types.size() != 2) continue;
    for (std::size_t known = 0; known < 2; ++known) {
      const std::size_t unknown = 1 - known;
      const Key pk = f->keys()[known], qk = f->keys()[unknown];
      if (!IsPose(types[known]) || !IsPoint(types[unknown]) || graph.IsFixed(qk) || !values->Has(pk)) continue;
      Params out;
      if (!f->Predict(known, values->Params(pk), unknown, out.data())) continue;
      const int n = AmbientDim(types[unknown]);
      if (!std::all_of(out.begin(), out.begin() + n, [](double v) { return std::isfinite(v); })) continue;
      Sum& p = points.try_emplace(qk, Sum{types[unknown]}).first->second;
      for (int i = 0; i < n; ++i) p.sum[i] += out[i];
      ++p.count;
    }
  }
  for (const auto& [k, p] : points) {
    const Eigen::Vector3d mean = p.sum / p.count;
    if (values->Has(k)) {
      std::copy(mean.data(), mean.data() + AmbientDim(p.type), values->Params(k));
    } else {
      values->InsertParams(k, p.type, mean.data());
    }
    ++s->points_set;
  }
}

}  // namespace

InitSummary Initialize(const FactorGraph& graph, Values* values, InitMethod method) {
  return Initialize(graph, values, method, LinearSolverType::kAuto);
}

InitSummary Initialize(const FactorGraph& graph, Values* values, InitMethod method,
                       const LinearSolverType& linear_solver) {
  if (values == nullptr) throw InvalidArgument("Initialize: values is a null pointer; pass the Values to initialise");
  const auto start = std::chrono::steady_clock::now();
  InitSummary s;
  s.method = method;
  Values work = *values;
  switch (method) {
    case InitMethod::kFile:
      break;
    case InitMethod::kSpanningTree:
      SpanningTree(graph, &work, &s);
      break;
    case InitMethod::kChordal:
      // Variables without a value get one from the spanning tree first, so that every pose the
      // pose-pose measurements do not reach (linked through points only, say) has one.
      InitializeSpanningTree(graph, &work);
      Chordal<2>(graph, &work, linear_solver).Run(&s);
      Chordal<3>(graph, &work, linear_solver).Run(&s);
      PointsFromPoses(graph, &work, &s);
      break;
  }
  *values = std::move(work);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char buf[200];
  std::snprintf(buf, sizeof buf, "initialisation '%s': %d poses and %d points set, %d anchors, %.3f s",
                ToString(method), s.poses_set, s.points_set, s.anchors, s.seconds);
  s.message = buf;
  return s;
}

}  // namespace tether
