#include "tether/core/variable.h"

#include <array>
#include <cmath>
#include <mutex>
#include <vector>

#include "tether/core/error.h"

namespace tether {

namespace internal {
const int kBuiltinAmbient[kNumBuiltinVarTypes] = {3, 7, 2, 3};
const int kBuiltinTangent[kNumBuiltinVarTypes] = {3, 6, 2, 3};
}  // namespace internal

namespace {

// Quaternions further than this from unit length are reported when normalised.
constexpr double kQuaternionNormWarning = 1e-3;

// The process-wide table. A description, once published, is never freed or changed (a
// replacement is a new description whose pointer takes the old one's place), so a description
// found once stays valid; readers need no lock (an id is only handed out after its entry is
// stored).
class Table {
 public:
  Table() {
    Add(DescribeVariable<SE2d>());
    Add(DescribeVariable<SE3d>());
    Add(DescribeVariable<Eigen::Vector2d>());
    Add(DescribeVariable<Eigen::Vector3d>());
  }

  VarType Intern(const VariableType& t) {
    std::lock_guard<std::mutex> lock(mutex_);
    const int n = size_.load(std::memory_order_relaxed);
    for (int i = 0; i < n; ++i) {
      const VariableType& e = *entries_[i].load(std::memory_order_acquire);
      if (e.name != t.name) continue;
      if (e.ambient_dim != t.ambient_dim || e.tangent_dim != t.tangent_dim) {
        throw InvalidArgument("variable type '" + t.name + "' exists already with " + Sizes(e) + " (owner '" + e.owner +
                              "'), not " + Sizes(t) + "; give the new type another name");
      }
      if (Same(e, t)) return static_cast<VarType>(i);
      if (holders_[i].load(std::memory_order_relaxed) > 0) {
        throw InvalidArgument("variable type '" + t.name + "' is registered already by '" + e.owner +
                              "' with another box-plus, box-minus, identity, canonical form or tag; give the new "
                              "type another name, or remove '" +
                              e.owner + "' from every registry first");
      }
      // No registry holds the old description (its plugin was refused or removed): the new one
      // takes its place under the same id.
      retired_.push_back(entries_[i].load(std::memory_order_relaxed));  // kept: a reader may hold it
      entries_[i].store(new VariableType(t), std::memory_order_release);
      return static_cast<VarType>(i);
    }
    if (n >= kMaxVarTypes) {
      throw InvalidArgument("cannot register variable type '" + t.name + "': the process holds " +
                            std::to_string(kMaxVarTypes) + " variable types already");
    }
    return Add(t);
  }

  const VariableType* Get(VarType t) const {
    const int i = static_cast<int>(t);
    return i < size_.load(std::memory_order_acquire) ? entries_[i].load(std::memory_order_acquire) : nullptr;
  }
  int size() const { return size_.load(std::memory_order_acquire); }
  void Hold(VarType t, int delta) { holders_[static_cast<int>(t)].fetch_add(delta, std::memory_order_relaxed); }

 private:
  static std::string Sizes(const VariableType& t) {
    return "ambient size " + std::to_string(t.ambient_dim) + " and tangent size " + std::to_string(t.tangent_dim);
  }
  static bool Same(const VariableType& a, const VariableType& b) {
    return a.retract == b.retract && a.local == b.local && a.identity == b.identity &&
           a.canonicalize == b.canonicalize && a.tag == b.tag;
  }
  VarType Add(const VariableType& t) {
    const int n = size_.load(std::memory_order_relaxed);
    entries_[n].store(new VariableType(t), std::memory_order_release);  // never freed: see above
    size_.store(n + 1, std::memory_order_release);
    return static_cast<VarType>(n);
  }

  std::mutex mutex_;
  std::array<std::atomic<const VariableType*>, kMaxVarTypes> entries_{};
  std::array<std::atomic<int>, kMaxVarTypes> holders_{};  // registries that hold each type
  std::atomic<int> size_{0};
  std::vector<const VariableType*> retired_;  // replaced descriptions, never freed
};

Table& GetTable() {
  static Table* table = new Table();  // never destroyed: plugins may outlive static destruction order
  return *table;
}

void Check(bool ok, const VariableType& t, const std::string& what) {
  if (!ok) {
    throw InvalidArgument("cannot register variable type '" + t.name + "' (owner '" + t.owner + "'): " + what);
  }
}

}  // namespace

bool VariableTraits<SE2d>::Canonicalize(double* x) {
  x[2] = WrapAngle(x[2]);
  return false;
}

bool VariableTraits<SE3d>::Canonicalize(double* x) {
  // stableNorm scales before squaring, so an entry above about 1e154 does not overflow the norm
  // to infinity (which would divide the quaternion to zeros).
  const double norm = Eigen::Map<const Eigen::Vector4d>(x + 3).stableNorm();
  if (!(norm > 1e-12)) {
    throw InvalidArgument("quaternion (qx qy qz qw) is zero; a rotation needs a unit quaternion");
  }
  for (int i = 3; i < 7; ++i) x[i] /= norm;
  return std::abs(norm - 1.0) > kQuaternionNormWarning;
}

VarType InternVariableType(const VariableType& t) {
  Check(!t.name.empty(), t, "the name is empty; give the type a unique name");
  Check(t.ambient_dim >= 1 && t.tangent_dim >= 1, t,
        "its sizes are ambient " + std::to_string(t.ambient_dim) + ", tangent " + std::to_string(t.tangent_dim) +
            "; both must be at least 1");
  Check(t.tangent_dim <= t.ambient_dim, t, "its tangent size exceeds its ambient size");
  Check(t.retract && t.local && t.identity, t, "it needs retract (box-plus), local (box-minus) and identity");
  return GetTable().Intern(t);
}

bool IsKnown(VarType t) { return GetTable().Get(t) != nullptr; }

namespace internal {
void HoldVariableType(VarType t) { GetTable().Hold(t, +1); }
void ReleaseVariableType(VarType t) { GetTable().Hold(t, -1); }
}  // namespace internal

const VariableType& Describe(VarType t) { return *GetTable().Get(t); }

namespace internal {
VarType FindRegisteredVarType(const char* name) {
  VarType t;
  if (FromString(name, &t)) return t;
  throw InvalidArgument(std::string("variable type '") + name +
                        "' is not registered; register it (Registry::RegisterVariable, or load the plugin that "
                        "defines it) before making factors or values of it");
}
}  // namespace internal

void IdentityParams(VarType t, double* p) { Describe(t).identity(p); }

std::string_view ToString(VarType t) {
  const VariableType* d = GetTable().Get(t);
  if (d == nullptr) return "unknown";
  return d->name;
}

bool FromString(std::string_view name, VarType* t) {
  const Table& table = GetTable();
  const int n = table.size();
  for (int i = 0; i < n; ++i) {
    if (table.Get(static_cast<VarType>(i))->name == name) {
      *t = static_cast<VarType>(i);
      return true;
    }
  }
  return false;
}

void LocalParams(VarType type, const double* x, const double* y, double* delta) {
  switch (type) {
    case VarType::kSE2: {
      const Eigen::Vector3d d = SE2d::FromParams(x).Local(SE2d::FromParams(y));
      for (int i = 0; i < 3; ++i) delta[i] = d[i];
      return;
    }
    case VarType::kSE3: {
      const Eigen::Matrix<double, 6, 1> d = SE3d::FromParams(x).Local(SE3d::FromParams(y));
      for (int i = 0; i < 6; ++i) delta[i] = d[i];
      return;
    }
    case VarType::kPoint2:
    case VarType::kPoint3:
      for (int i = 0; i < AmbientDim(type); ++i) delta[i] = y[i] - x[i];
      return;
    default:
      Describe(type).local(x, y, delta);
  }
}

}  // namespace tether
