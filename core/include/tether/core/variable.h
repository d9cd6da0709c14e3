#pragma once
// Variable types: what a Values can hold. Every type, built-in or a plugin's, is described by
// one VariableType (name, g2o vertex tag, ambient and tangent size, box-plus, box-minus,
// identity, optional canonical form for values read from files) and registered the same way
// (Registry::RegisterVariable, PluginRegistrar::AddVariableType).
//
// The four built-in types have fixed ids:
//
// | type   | g2o tag          | ambient params              | tangent | retraction (box-plus)          |
// |--------|------------------|-----------------------------|---------|--------------------------------|
// | SE2    | VERTEX_SE2       | x y theta                   | 3       | t + R dt, theta + dtheta       |
// | SE3    | VERTEX_SE3:QUAT  | tx ty tz qx qy qz qw        | 6       | t + R dt, R Exp(dw)            |
// | Point2 | VERTEX_XY        | x y                         | 2       | p + d                          |
// | Point3 | VERTEX_TRACKXYZ  | x y z                       | 3       | p + d                          |
//
// Other types get the next free id when first registered; the id stays the same for the life
// of the process (registering the same name again gives the same id).
//
// In C++ a variable type is also a value type with a VariableTraits specialisation (SE2d,
// SE3d, Eigen::Vector2d, Eigen::Vector3d are built in): Values::Insert/At/Update take such
// values, and TypedFactor / AutoDiffFactor list the types of their keys by them.
#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

#include "tether/core/error.h"
#include "tether/core/se2.h"
#include "tether/core/se3.h"

namespace tether {

/// The id of a variable type. Values past kPoint3 are types registered at run time.
enum class VarType : std::uint16_t { kSE2 = 0, kSE3 = 1, kPoint2 = 2, kPoint3 = 3 };
constexpr int kNumBuiltinVarTypes = 4;
/// At most this many variable types can be registered in one process.
constexpr int kMaxVarTypes = 1024;

/// Everything tether knows about one variable type at run time.
struct VariableType {
  using RetractFn = void (*)(const double* x, const double* delta, double* out);
  using LocalFn = void (*)(const double* x, const double* y, double* delta);
  using IdentityFn = void (*)(double* x);
  /// Brings parameters read from a file to their canonical form in place (wraps an angle,
  /// normalises a quaternion). Returns true where it changed them noticeably (the reader
  /// then warns once per file with `canonicalize_note`); throws InvalidArgument for values
  /// that cannot be made valid (a zero quaternion).
  using CanonicalizeFn = bool (*)(double* x);

  std::string name;                       ///< unique type name, e.g. "SE2"
  std::string tag;                        ///< g2o vertex tag, e.g. "VERTEX_SE2" (empty: no file form)
  std::string owner = "builtin";          ///< who registered it (plugin name for plugins)
  int ambient_dim = 0;                    ///< stored parameters
  int tangent_dim = 0;                    ///< size of a box-plus step
  std::string parameter_names;            ///< "x y theta", for messages (default p1 .. pn)
  RetractFn retract = nullptr;            ///< out = x (+) delta; x and out may alias
  LocalFn local = nullptr;                ///< delta with x (+) delta == y
  IdentityFn identity = nullptr;          ///< the type's origin (a spanning-tree start, a probe)
  CanonicalizeFn canonicalize = nullptr;  ///< optional (see above)
  std::string canonicalize_note;          ///< what canonicalize did, e.g. "normalised quaternions"
};

/// Puts `type` into the process-wide table of variable types (or finds it there, by name) and
/// returns its id. Throws InvalidArgument where the description is incomplete, where a type of
/// that name exists already with other sizes, or where one exists with another box-plus,
/// box-minus, identity, canonical form or tag and some registry holds it (a description no
/// registry holds, such as a refused plugin's, is replaced, keeping its id).
VarType InternVariableType(const VariableType& type);
/// True for the built-in ids and every id InternVariableType has handed out.
bool IsKnown(VarType t);
/// The description of a known id (behaviour is undefined for an unknown one: check IsKnown).
const VariableType& Describe(VarType t);

namespace internal {
extern const int kBuiltinAmbient[kNumBuiltinVarTypes];
extern const int kBuiltinTangent[kNumBuiltinVarTypes];
}  // namespace internal

inline int TangentDim(VarType t) {
  const unsigned i = static_cast<unsigned>(t);
  return i < kNumBuiltinVarTypes ? internal::kBuiltinTangent[i] : Describe(t).tangent_dim;
}
inline int AmbientDim(VarType t) {
  const unsigned i = static_cast<unsigned>(t);
  return i < kNumBuiltinVarTypes ? internal::kBuiltinAmbient[i] : Describe(t).ambient_dim;
}
/// The identity (origin) of a type in its ambient parameters.
void IdentityParams(VarType t, double* p);
/// The type's name ("SE2", "Point2", or a registered name); "unknown" for an unknown id.
std::string_view ToString(VarType t);
/// Inverse of ToString over every known type; returns false for an unknown name.
bool FromString(std::string_view name, VarType* t);
inline bool IsPose(VarType t) { return t == VarType::kSE2 || t == VarType::kSE3; }
inline bool IsPoint(VarType t) { return t == VarType::kPoint2 || t == VarType::kPoint3; }

/// Box-plus on raw parameters: out = x (+) delta; x and out may alias. Built-in types take
/// any scalar (automatic differentiation uses it with ceres::Jet); registered types only
/// double (their templated box-plus is VariableTraits<V>::Retract).
template <typename T>
void RetractParams(VarType type, const T* x, const T* delta, T* out) {
  switch (type) {
    case VarType::kSE2:
      SE2<T>::FromParams(x).Retract(Eigen::Matrix<T, 3, 1>(delta[0], delta[1], delta[2])).ToParams(out);
      return;
    case VarType::kSE3: {
      Eigen::Matrix<T, 6, 1> d;
      for (int i = 0; i < 6; ++i) d[i] = delta[i];
      SE3<T>::FromParams(x).Retract(d).ToParams(out);
      return;
    }
    case VarType::kPoint2:
      for (int i = 0; i < 2; ++i) out[i] = x[i] + delta[i];
      return;
    case VarType::kPoint3:
      for (int i = 0; i < 3; ++i) out[i] = x[i] + delta[i];
      return;
    default:
      if constexpr (std::is_same_v<T, double>) {
        Describe(type).retract(x, delta, out);
      } else {
        (void)x, (void)delta, (void)out;
        throw InvalidArgument("variable type '" + std::string(ToString(type)) +
                              "' has no templated box-plus here; differentiate through "
                              "VariableTraits<V>::Retract (AutoDiffFactor with the value type) instead");
      }
  }
}

/// Box-minus on raw parameters: delta with x (+) delta == y.
void LocalParams(VarType type, const double* x, const double* y, double* delta);

// ---- variable types as C++ value types ----

/// Specialise for a value type to make it a variable type. A specialisation states
///   static constexpr const char* kName;       // the type name
///   static constexpr const char* kTag;        // g2o vertex tag ("" for none)
///   static constexpr const char* kParameterNames;  // "x y theta" (may be "")
///   static constexpr int kAmbient, kTangent;
///   template <typename T> static void Retract(const T* x, const T* delta, T* out);
///   static void Local(const double* x, const double* y, double* delta);
///   static void Identity(double* x);
///   static Value FromParams(const double* p);  static void ToParams(const Value& v, double* p);
/// and optionally `static constexpr VarType kBuiltin` (built-in types only) and
/// `static bool Canonicalize(double* x)` with `static constexpr const char* kCanonicalizeNote`.
template <class V>
struct VariableTraits;

namespace internal {
template <class V, class = void>
struct HasBuiltinId : std::false_type {};
template <class V>
struct HasBuiltinId<V, std::void_t<decltype(VariableTraits<V>::kBuiltin)>> : std::true_type {};
template <class V, class = void>
struct HasCanonicalize : std::false_type {};
template <class V>
struct HasCanonicalize<V, std::void_t<decltype(&VariableTraits<V>::Canonicalize)>> : std::true_type {};
/// The id of a registered type by name; throws InvalidArgument naming it where it is not registered.
VarType FindRegisteredVarType(const char* name);
/// Registries count themselves as holders of the types they register (Registry does this).
void HoldVariableType(VarType t);
void ReleaseVariableType(VarType t);
}  // namespace internal

/// The run-time description of the value type V (for Registry::RegisterVariable).
template <class V>
VariableType DescribeVariable() {
  using Tr = VariableTraits<V>;
  VariableType t;
  t.name = Tr::kName;
  t.tag = Tr::kTag;
  t.parameter_names = Tr::kParameterNames;
  t.ambient_dim = Tr::kAmbient;
  t.tangent_dim = Tr::kTangent;
  t.retract = [](const double* x, const double* d, double* out) { Tr::template Retract<double>(x, d, out); };
  t.local = &Tr::Local;
  t.identity = &Tr::Identity;
  if constexpr (internal::HasCanonicalize<V>::value) {
    t.canonicalize = &Tr::Canonicalize;
    t.canonicalize_note = Tr::kCanonicalizeNote;
  }
  return t;
}

/// The id of the value type V. Built-in types have theirs at compile time; others are looked
/// up by name (they must be registered: Registry::RegisterVariable or a plugin).
template <class V>
VarType VarTypeOf() {
  if constexpr (internal::HasBuiltinId<V>::value) {
    return VariableTraits<V>::kBuiltin;
  } else {
    static std::atomic<int> cached{-1};
    int id = cached.load(std::memory_order_acquire);
    if (id < 0) {
      id = static_cast<int>(internal::FindRegisteredVarType(VariableTraits<V>::kName));
      cached.store(id, std::memory_order_release);
    }
    return static_cast<VarType>(id);
  }
}

/// What the two built-in pose types share: box-plus and box-minus through RetractParams and
/// LocalParams, conversion through the group's own parameter layout.
template <class Pose, VarType kId, int kAmbientDim, int kTangentDim>
struct PoseTraits {
  static constexpr VarType kBuiltin = kId;
  static constexpr int kAmbient = kAmbientDim, kTangent = kTangentDim;
  template <typename T>
  static void Retract(const T* x, const T* d, T* out) {
    RetractParams<T>(kBuiltin, x, d, out);
  }
  static void Local(const double* x, const double* y, double* d) { LocalParams(kBuiltin, x, y, d); }
  static Pose FromParams(const double* p) { return Pose::FromParams(p); }
  static void ToParams(const Pose& v, double* p) { v.ToParams(p); }
};

template <>
struct VariableTraits<SE2d> : PoseTraits<SE2d, VarType::kSE2, 3, 3> {
  static constexpr const char* kName = "SE2";
  static constexpr const char* kTag = "VERTEX_SE2";
  static constexpr const char* kParameterNames = "x y theta";
  static void Identity(double* x) { x[0] = x[1] = x[2] = 0.0; }
  static bool Canonicalize(double* x);  // wraps theta to (-pi, pi]
  static constexpr const char* kCanonicalizeNote = "";
};

template <>
struct VariableTraits<SE3d> : PoseTraits<SE3d, VarType::kSE3, 7, 6> {
  static constexpr const char* kName = "SE3";
  static constexpr const char* kTag = "VERTEX_SE3:QUAT";
  static constexpr const char* kParameterNames = "x y z qx qy qz qw";
  static void Identity(double* x) {
    for (int i = 0; i < 6; ++i) x[i] = 0.0;
    x[6] = 1.0;
  }
  /// Normalises the quaternion; true where it was more than 1e-3 from unit length. Throws
  /// InvalidArgument for a zero quaternion.
  static bool Canonicalize(double* x);
  static constexpr const char* kCanonicalizeNote = "normalised quaternions that were far from unit length";
};

template <int N, VarType kId>
struct PointTraits {
  static constexpr VarType kBuiltin = kId;
  static constexpr int kAmbient = N, kTangent = N;
  template <typename T>
  static void Retract(const T* x, const T* d, T* out) {
    for (int i = 0; i < N; ++i) out[i] = x[i] + d[i];
  }
  static void Local(const double* x, const double* y, double* d) {
    for (int i = 0; i < N; ++i) d[i] = y[i] - x[i];
  }
  static void Identity(double* x) {
    for (int i = 0; i < N; ++i) x[i] = 0.0;
  }
  static Eigen::Matrix<double, N, 1> FromParams(const double* p) { return Eigen::Matrix<double, N, 1>(p); }
  static void ToParams(const Eigen::Matrix<double, N, 1>& v, double* p) {
    for (int i = 0; i < N; ++i) p[i] = v[i];
  }
};

template <>
struct VariableTraits<Eigen::Vector2d> : PointTraits<2, VarType::kPoint2> {
  static constexpr const char* kName = "Point2";
  static constexpr const char* kTag = "VERTEX_XY";
  static constexpr const char* kParameterNames = "x y";
};

template <>
struct VariableTraits<Eigen::Vector3d> : PointTraits<3, VarType::kPoint3> {
  static constexpr const char* kName = "Point3";
  static constexpr const char* kTag = "VERTEX_TRACKXYZ";
  static constexpr const char* kParameterNames = "x y z";
};

}  // namespace tether
