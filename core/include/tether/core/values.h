#pragma once
// Values: the state of a problem, one entry per variable, kept in contiguous typed storage.
//
// Each variable type has one flat array of doubles (its parameters back to back), and a
// hash map finds a key's type and slot. Ids are never used as indices, so a key such as
// 4000000000 costs no more memory than key 0. Pointers returned by Params() stay valid
// until the next Insert.
//
// One naming scheme for every variable type, built-in or registered (variable.h):
//   values.Insert(k, SE2d(1, 2, 0.3));        values.Insert(k, Eigen::Vector2d(4, 5));
//   SE2d x = values.At<SE2d>(k);             values.Update(k, x);
// and the raw form InsertParams / Params for code that works on any type.
#include <Eigen/Core>
#include <iosfwd>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "tether/core/key.h"
#include "tether/core/variable.h"

namespace tether {

namespace internal {
template <class V, class = void>
struct IsVariable : std::false_type {};
template <class V>
struct IsVariable<V, std::void_t<decltype(VariableTraits<V>::kAmbient)>> : std::true_type {};
}  // namespace internal

class Values {
 public:
  struct Slot {
    VarType type;
    std::uint32_t index;
  };

  bool Has(Key k) const { return slots_.count(k) != 0; }
  std::size_t size() const { return order_.size(); }
  bool empty() const { return order_.empty(); }
  /// Keys in insertion order.
  const std::vector<Key>& keys() const { return order_; }

  /// Inserts a new variable of the value's type; throws InvalidArgument if the key exists.
  template <class V, std::enable_if_t<internal::IsVariable<V>::value, int> = 0>
  void Insert(Key k, const V& v) {
    double p[VariableTraits<V>::kAmbient];
    VariableTraits<V>::ToParams(v, p);
    InsertParams(k, VarTypeOf<V>(), p);
  }
  /// A fixed-size Eigen expression of 2 or 3 entries inserts a Point2 or Point3.
  template <class D, std::enable_if_t<!internal::IsVariable<D>::value, int> = 0>
  void Insert(Key k, const Eigen::MatrixBase<D>& p) {
    static_assert(D::SizeAtCompileTime == 2 || D::SizeAtCompileTime == 3, "a point has 2 or 3 coordinates");
    const Eigen::Matrix<double, D::SizeAtCompileTime, 1> q = p;
    Insert(k, q);
  }
  /// Inserts from raw parameters of the given type.
  void InsertParams(Key k, VarType type, const double* params);

  /// The value of `k`; throws InvalidArgument naming the key when it is missing or of another type.
  template <class V>
  V At(Key k) const {
    ExpectType(k, VarTypeOf<V>());
    return VariableTraits<V>::FromParams(Params(k));
  }
  /// Replaces the value of an existing variable of the same type (throws as At does).
  template <class V, std::enable_if_t<internal::IsVariable<V>::value, int> = 0>
  void Update(Key k, const V& v) {
    ExpectType(k, VarTypeOf<V>());
    VariableTraits<V>::ToParams(v, Params(k));
  }
  /// Removes a variable. Pointers from Params() of other variables of its type may move.
  /// Returns false where there is no such key.
  bool Erase(Key k);

  VarType TypeOf(Key k) const { return SlotOf(k).type; }
  Slot SlotOf(Key k) const;
  double* Params(Key k);
  const double* Params(Key k) const;

  /// Applies box-plus to one variable.
  void Retract(Key k, const double* delta);

  /// Number of variables of each type.
  std::size_t Count(VarType t) const;
  /// All parameters of one type, back to back, in insertion order of that type.
  const std::vector<double>& Data(VarType t) const;
  std::vector<double>& MutableData(VarType t);

 private:
  void ExpectType(Key k, VarType want) const;

  std::unordered_map<Key, Slot> slots_;
  std::vector<Key> order_;
  std::vector<std::vector<double>> data_;  // indexed by type id
};

/// One line per variable: "x12 SE2 (1, 2, 0.3)".
std::ostream& operator<<(std::ostream& os, const Values& values);

}  // namespace tether
