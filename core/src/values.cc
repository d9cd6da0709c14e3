#include "tether/core/values.h"

#include "tether/core/error.h"

namespace tether {

void Values::InsertParams(Key k, VarType type, const double* params) {
  std::vector<double>& d = data_[static_cast<int>(type)];
  const int n = AmbientDim(type);
  const auto index = static_cast<std::uint32_t>(d.size() / n);
  if (!slots_.emplace(k, Slot{type, index}).second) {
    throw InvalidArgument("Values::Insert: key " + KeyToString(k) + " exists already (as " +
                          std::string(ToString(TypeOf(k))) + "); use a new key or update it");
  }
  d.insert(d.end(), params, params + n);
  order_.push_back(k);
}

void Values::Insert(Key k, const SE2d& v) {
  double p[3];
  v.ToParams(p);
  InsertParams(k, VarType::kSE2, p);
}
void Values::Insert(Key k, const SE3d& v) {
  double p[7];
  v.ToParams(p);
  InsertParams(k, VarType::kSE3, p);
}
void Values::InsertPoint2(Key k, const Eigen::Vector2d& p) { InsertParams(k, VarType::kPoint2, p.data()); }
void Values::InsertPoint3(Key k, const Eigen::Vector3d& p) { InsertParams(k, VarType::kPoint3, p.data()); }

Values::Slot Values::SlotOf(Key k) const {
  const auto it = slots_.find(k);
  if (it == slots_.end()) {
    throw InvalidArgument("Values: no variable with key " + KeyToString(k) +
                          "; insert it (or check the factor's keys)");
  }
  return it->second;
}

const double* Values::Params(Key k) const {
  const Slot s = SlotOf(k);
  return data_[static_cast<int>(s.type)].data() + static_cast<std::size_t>(s.index) * AmbientDim(s.type);
}
double* Values::Params(Key k) {
  const Slot s = SlotOf(k);
  return data_[static_cast<int>(s.type)].data() + static_cast<std::size_t>(s.index) * AmbientDim(s.type);
}

namespace {
void ExpectType(const Values& v, Key k, VarType want) {
  const VarType got = v.TypeOf(k);
  if (got != want) {
    throw InvalidArgument("Values: key " + KeyToString(k) + " holds " + std::string(ToString(got)) + ", not " +
                          std::string(ToString(want)));
  }
}
}  // namespace

SE2d Values::AtSE2(Key k) const {
  ExpectType(*this, k, VarType::kSE2);
  return SE2d::FromParams(Params(k));
}
SE3d Values::AtSE3(Key k) const {
  ExpectType(*this, k, VarType::kSE3);
  return SE3d::FromParams(Params(k));
}
Eigen::Vector2d Values::AtPoint2(Key k) const {
  ExpectType(*this, k, VarType::kPoint2);
  return Eigen::Vector2d(Params(k));
}
Eigen::Vector3d Values::AtPoint3(Key k) const {
  ExpectType(*this, k, VarType::kPoint3);
  return Eigen::Vector3d(Params(k));
}
void Values::Update(Key k, const SE2d& v) {
  ExpectType(*this, k, VarType::kSE2);
  v.ToParams(Params(k));
}
void Values::Update(Key k, const SE3d& v) {
  ExpectType(*this, k, VarType::kSE3);
  v.ToParams(Params(k));
}

void Values::Retract(Key k, const double* delta) {
  const VarType t = TypeOf(k);
  double* p = Params(k);
  RetractParams<double>(t, p, delta, p);
}

}  // namespace tether
