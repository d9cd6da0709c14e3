#pragma once
// Values: the state of a problem, one entry per variable, kept in contiguous typed storage.
//
// Each variable type has one flat array of doubles (its parameters back to back), and a
// hash map finds a key's type and slot. Ids are never used as indices, so a key such as
// 4000000000 costs no more memory than key 0. Pointers returned by Params() stay valid
// until the next Insert.
#include <Eigen/Core>
#include <unordered_map>
#include <vector>

#include "tether/core/key.h"
#include "tether/core/variable.h"

namespace tether {

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

  /// Inserts a new variable; throws InvalidArgument if the key exists already.
  void Insert(Key k, const SE2d& v);
  void Insert(Key k, const SE3d& v);
  void InsertPoint2(Key k, const Eigen::Vector2d& p);
  void InsertPoint3(Key k, const Eigen::Vector3d& p);
  /// Inserts from raw parameters of the given type.
  void InsertParams(Key k, VarType type, const double* params);

  /// Throws InvalidArgument naming the key when it is missing or of another type.
  SE2d AtSE2(Key k) const;
  SE3d AtSE3(Key k) const;
  Eigen::Vector2d AtPoint2(Key k) const;
  Eigen::Vector3d AtPoint3(Key k) const;

  void Update(Key k, const SE2d& v);
  void Update(Key k, const SE3d& v);

  VarType TypeOf(Key k) const { return SlotOf(k).type; }
  Slot SlotOf(Key k) const;
  double* Params(Key k);
  const double* Params(Key k) const;

  /// Applies box-plus to one variable.
  void Retract(Key k, const double* delta);

  /// Number of variables of each type.
  std::size_t Count(VarType t) const { return data_[static_cast<int>(t)].size() / AmbientDim(t); }
  /// All parameters of one type, back to back, in insertion order of that type.
  const std::vector<double>& Data(VarType t) const { return data_[static_cast<int>(t)]; }
  std::vector<double>& MutableData(VarType t) { return data_[static_cast<int>(t)]; }

 private:
  std::unordered_map<Key, Slot> slots_;
  std::vector<Key> order_;
  std::vector<double> data_[kNumVarTypes];
};

}  // namespace tether
