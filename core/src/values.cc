#include "tether/core/values.h"

#include <algorithm>
#include <cmath>
#include <ostream>

#include "tether/core/error.h"

namespace tether {

namespace {
const std::vector<double>& EmptyData() {
  static const std::vector<double> empty;
  return empty;
}
}  // namespace

namespace {

// A value the type's canonical form rejects (a zero quaternion) is refused where it comes in:
// it would solve to nonsense and be written into a file the reader refuses. Non-finite values
// are left to the solvers (which name the factor and keys) and the writer (which refuses them).
void CheckParams(Key k, VarType type, const double* params) {
  const VariableType& d = Describe(type);
  if (d.canonicalize == nullptr) return;
  for (int i = 0; i < d.ambient_dim; ++i) {
    if (!std::isfinite(params[i])) return;  // the solvers report it, naming the factor and keys
  }
  double copy[64];
  std::vector<double> big;
  double* x = copy;
  if (d.ambient_dim > 64) {
    big.assign(params, params + d.ambient_dim);
    x = big.data();
  } else {
    std::copy(params, params + d.ambient_dim, copy);
  }
  try {
    d.canonicalize(x);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument("Values::Insert: key " + KeyToString(k) + " (" + d.name + "): " + e.what());
  }
}

}  // namespace

void Values::InsertParams(Key k, VarType type, const double* params) {
  if (!IsKnown(type)) {
    throw InvalidArgument("Values::Insert: key " + KeyToString(k) + " has variable type id " +
                          std::to_string(static_cast<int>(type)) + ", which is not registered");
  }
  const int n = AmbientDim(type);
  CheckParams(k, type, params);
  const std::size_t t = static_cast<std::size_t>(type);
  if (data_.size() <= t) data_.resize(t + 1);
  std::vector<double>& d = data_[t];
  const auto index = static_cast<std::uint32_t>(d.size() / n);
  if (!slots_.emplace(k, Slot{type, index}).second) {
    throw InvalidArgument("Values::Insert: key " + KeyToString(k) + " exists already (as " +
                          std::string(ToString(TypeOf(k))) + "); use a new key or update it");
  }
  d.insert(d.end(), params, params + n);
  order_.push_back(k);
}

bool Values::Erase(Key k) {
  const auto it = slots_.find(k);
  if (it == slots_.end()) return false;
  const Slot s = it->second;
  std::vector<double>& d = data_[static_cast<std::size_t>(s.type)];
  const std::size_t n = static_cast<std::size_t>(AmbientDim(s.type));
  const std::uint32_t last = static_cast<std::uint32_t>(d.size() / n - 1);
  if (s.index != last) {
    // The type's last variable moves into the freed slot.
    std::copy(d.begin() + last * n, d.begin() + (last + 1) * n, d.begin() + s.index * n);
    for (auto& kv : slots_) {
      if (kv.second.type == s.type && kv.second.index == last) {
        kv.second.index = s.index;
        break;
      }
    }
  }
  d.resize(last * n);
  slots_.erase(it);
  order_.erase(std::find(order_.begin(), order_.end(), k));
  return true;
}

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
  return data_[static_cast<std::size_t>(s.type)].data() + static_cast<std::size_t>(s.index) * AmbientDim(s.type);
}
double* Values::Params(Key k) {
  const Slot s = SlotOf(k);
  return data_[static_cast<std::size_t>(s.type)].data() + static_cast<std::size_t>(s.index) * AmbientDim(s.type);
}

void Values::ExpectType(Key k, VarType want) const {
  const VarType got = TypeOf(k);
  if (got != want) {
    throw InvalidArgument("Values: key " + KeyToString(k) + " holds " + std::string(ToString(got)) + ", not " +
                          std::string(ToString(want)));
  }
}

void Values::Retract(Key k, const double* delta) {
  const VarType t = TypeOf(k);
  double* p = Params(k);
  RetractParams<double>(t, p, delta, p);
}

std::size_t Values::Count(VarType t) const { return Data(t).size() / AmbientDim(t); }

const std::vector<double>& Values::Data(VarType t) const {
  const std::size_t i = static_cast<std::size_t>(t);
  return i < data_.size() ? data_[i] : EmptyData();
}

std::vector<double>& Values::MutableData(VarType t) {
  const std::size_t i = static_cast<std::size_t>(t);
  if (data_.size() <= i) data_.resize(i + 1);
  return data_[i];
}

std::ostream& operator<<(std::ostream& os, const Values& values) {
  for (Key k : values.keys()) {
    const VarType t = values.TypeOf(k);
    const double* p = values.Params(k);
    os << KeyToString(k) << ' ' << ToString(t) << " (";
    for (int i = 0; i < AmbientDim(t); ++i) os << (i ? ", " : "") << p[i];
    os << ")\n";
  }
  return os;
}

}  // namespace tether
