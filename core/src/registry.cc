#include "tether/core/registry.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>

#include "tether/core/error.h"

namespace tether {

namespace {

// Names of a variable type's parameters, as g2o's vertex lines list them.
std::string ParameterNames(VarType t) { return Describe(t).parameter_names; }

std::string TypeList(const std::vector<VarType>& types) {
  std::string s = "(";
  for (std::size_t i = 0; i < types.size(); ++i) s += (i ? ", " : "") + std::string(ToString(types[i]));
  return s + ")";
}

// "id1 id2 x y theta I11 I12 I13 I22 I23 I33": the standard layout, for messages.
std::string StandardLayout(const FactorType& t) {
  std::string s;
  const std::size_t n = t.variable_types.size();
  for (std::size_t i = 0; i < n; ++i) s += (i ? " id" : "id") + std::to_string(i + 1);
  std::string m = t.measurement_layout;
  if (VarType last; m.empty() && MeasurementIsAValue(t, &last)) m = ParameterNames(last);
  if (m.empty()) {
    for (int i = 0; i < t.measurement_size; ++i) m += (i ? " m" : "m") + std::to_string(i + 1);
  }
  if (!m.empty()) s += " " + m;
  for (int i = 0; i < t.dim; ++i)
    for (int j = i; j < t.dim; ++j) s += " I" + std::to_string(i + 1) + std::to_string(j + 1);
  return s;
}

std::string Owned(const FactorType& t) { return "'" + t.name + "' (owner '" + t.owner + "')"; }

// What else a user can do about a clash: a plugin's types can be removed, built-in ones cannot.
std::string UnloadHint(const FactorType& holder) {
  if (holder.owner.empty() || holder.owner == "builtin") return " (built-in types cannot be removed)";
  return " or unload '" + holder.owner + "' first";
}

}  // namespace

bool MeasurementIsAValue(const FactorType& t, VarType* type) {
  if (t.variable_types.empty()) return false;
  const VarType last = t.variable_types.back();
  if (AmbientDim(last) != t.measurement_size) return false;
  if (!t.measurement_layout.empty() && t.measurement_layout != ParameterNames(last)) return false;
  if (type != nullptr) *type = last;
  return true;
}

namespace {

// The text of a short decimal v = r / 10^k (at most 8 decimals, |v| < 10^7), where it is what
// std::to_chars gives: most measurements and information entries are such decimals (files give
// them with a few digits), and the general shortest-round-trip search costs several times more.
// False where v is not one, or where to_chars would write it in scientific notation.
//
// Why the text is to_chars' own: r8 = v * 10^8 rounded, and r8 / 10^8 == v (a division of exact
// doubles, so correctly rounded, as reading the text back is) says that the decimal r8 / 10^8
// reads back as v. Below 10^15, v * 10^8 as computed is within 0.2 of any decimal with at most
// 8 decimals that reads back as v, so that decimal is r8 / 10^8: there is one, and with its
// trailing zeros dropped it is the shortest digit string that reads back as v (to_chars'
// choice). to_chars writes it in fixed notation where that is shorter than scientific;
// otherwise (a tie included) this declines.
bool AppendShortDecimal(std::string* s, double v) {
  const double a = std::fabs(v);
  if (!(a >= 1e-3 && a < 1e7)) return false;
  const double r8 = std::nearbyint(a * 1e8);
  if (r8 / 1e8 != a) return false;
  auto r = static_cast<std::uint64_t>(r8);
  int k = 8;
  while (k > 0 && r % 10 == 0) {
    r /= 10;
    --k;
  }
  char digits[24];
  const int n = static_cast<int>(std::to_chars(digits, digits + sizeof digits, r).ptr - digits);
  int zeros = 0;  // trailing zeros of r (only where k is 0)
  while (zeros < n - 1 && digits[n - 1 - zeros] == '0') ++zeros;
  const int significant = n - zeros;
  const int fixed = k == 0 ? n : n > k ? n + 1 : k + 2;                // ddd, dd.d or 0.00d
  const int scientific = significant + (significant > 1 ? 1 : 0) + 4;  // d[.ddd]e+XX
  if (fixed >= scientific) return false;
  if (v < 0) s->push_back('-');
  if (k == 0) {
    s->append(digits, n);
  } else if (n > k) {
    s->append(digits, n - k);
    s->push_back('.');
    s->append(digits + n - k, k);
  } else {
    s->append("0.");
    s->append(k - n, '0');
    s->append(digits, n);
  }
  return true;
}

}  // namespace

void AppendDouble(std::string* s, double v) {
  if (v == 0) {
    s->append(std::signbit(v) ? "-0" : "0");
    return;
  }
  if (AppendShortDecimal(s, v)) return;
  // std::to_chars without a format gives the shortest text that reads back as the same double.
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  s->append(buf, r.ptr);
}

void AppendKey(std::string* s, Key k) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, k);
  s->append(buf, r.ptr);
}

std::string FormatFixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

std::string FormatDouble(double v) {
  std::string s;
  AppendDouble(&s, v);
  return s;
}

SqrtInformation ReadContext::FromInformation(const Fields& f, Eigen::MatrixXd omega) {
  SqrtInformation out;
  std::string why;
  if (SqrtInformation::TryFromInformation(omega, &out, &why)) return out;
  if (repair == InformationRepair::kNone) {
    f.Fail(std::string(f.tag()) + ": " + why + "; fix the file or pass --repair-information nearest-pd|isotropic");
  }
  if (RepairInformation(repair, &omega)) {
    if (repaired_informations++ == 0) first_repaired_line = f.line_number();
  }
  if (!SqrtInformation::TryFromInformation(omega, &out, &why)) {
    f.Fail("information matrix of " + std::string(f.tag()) + " is not positive definite even after repair '" +
           ToString(repair) + "' (" + why + "); fix the file");
  }
  return out;
}

SqrtInformation ReadContext::ReadUpperInformation(const Fields& f, std::size_t first, int dim) {
  // Up to 6 x 6 (every built-in edge) the matrix lives on the stack: this runs for every edge
  // of a file.
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kInlineResidualDim, kInlineResidualDim>;
  if (dim >= 1 && dim <= kInlineResidualDim) {
    Small omega(dim, dim);
    std::size_t k = first;
    for (int i = 0; i < dim; ++i) {
      for (int j = i; j < dim; ++j) {
        omega(i, j) = f.Double(k++);
        omega(j, i) = omega(i, j);
      }
    }
    SqrtInformation out;
    if (SqrtInformation::TryFromInformation(omega, &out, nullptr)) return out;
    return FromInformation(f, Eigen::MatrixXd(omega));  // refused: the message, or the repair
  }
  Eigen::MatrixXd omega(dim, dim);
  std::size_t k = first;
  for (int i = 0; i < dim; ++i) {
    for (int j = i; j < dim; ++j) {
      omega(i, j) = f.Double(k++);
      omega(j, i) = omega(i, j);
    }
  }
  return FromInformation(f, std::move(omega));
}

void Registry::Register(FactorType type) {
  const auto incomplete = [&](const std::string& what) {
    throw InvalidArgument("cannot register factor type " + Owned(type) + ": " + what);
  };
  if (type.name.empty()) incomplete("the name is empty; give the type a unique name");
  const auto same_name = by_name_.find(type.name);
  if (same_name != by_name_.end()) {
    throw InvalidArgument("cannot register factor type " + Owned(type) + ": the name is taken already by " +
                          Owned(same_name->second) + "; choose another name" + UnloadHint(same_name->second));
  }
  if (!type.tag.empty()) {
    const auto same_tag = tag_to_name_.find(type.tag);
    if (same_tag != tag_to_name_.end()) {
      throw InvalidArgument("cannot register factor type " + Owned(type) + ": the g2o tag '" + type.tag +
                            "' is taken already by " + Owned(by_name_.at(same_tag->second)) + "; choose another tag" +
                            UnloadHint(by_name_.at(same_tag->second)));
    }
    if (type.tag.find_first_of(" \t\r\n") != std::string::npos || type.tag[0] == '#') {
      incomplete("the g2o tag '" + type.tag + "' contains blanks or starts with '#'; use one word");
    }
  }
  if (type.dim < 1) incomplete("its residual dimension is " + std::to_string(type.dim) + "; it must be at least 1");
  if (type.variable_types.empty()) incomplete("it lists no variable types; a factor needs at least one key");
  for (VarType v : type.variable_types) {
    if (!IsKnown(v)) {
      incomplete("variable type id " + std::to_string(static_cast<int>(v)) +
                 " is not registered; register the variable type first");
    }
  }
  if (!type.tag.empty() && vertex_tag_to_name_.count(type.tag) != 0) {
    incomplete("the g2o tag '" + type.tag + "' is the vertex tag of variable type '" +
               vertex_tag_to_name_.at(type.tag) + "'; choose another tag");
  }
  if (type.measurement_size < 0) incomplete("its measurement_size is negative");
  if (!type.tag.empty()) {
    if (!type.read && !type.make) {
      incomplete("it has a g2o tag but neither `make` (standard layout) nor `read`; give one of them");
    }
    if (!type.write && !type.measurement) {
      incomplete("it has a g2o tag but neither `measurement` (standard layout) nor `write`; give one of them");
    }
  }
  if (type.make) CheckAgainstProbe(type);
  // The type first, then its tag: if adding the tag runs out of memory, the type is taken out
  // again and the registry is as it was.
  const std::string name = type.name, tag = type.tag;
  const auto added = by_name_.emplace(name, std::move(type)).first;
  if (!tag.empty()) {
    try {
      tag_to_name_.emplace(tag, name);
    } catch (...) {
      by_name_.erase(added);
      throw;
    }
  }
}

Registry::Registry(const Registry& other)
    : by_name_(other.by_name_),
      tag_to_name_(other.tag_to_name_),
      variables_(other.variables_),
      variable_owner_(other.variable_owner_),
      variable_tag_(other.variable_tag_),
      vertex_tag_to_name_(other.vertex_tag_to_name_) {
  for (const auto& kv : variables_) internal::HoldVariableType(kv.second);
}

Registry& Registry::operator=(const Registry& other) {
  if (this != &other) {
    for (const auto& kv : other.variables_) internal::HoldVariableType(kv.second);
    for (const auto& kv : variables_) internal::ReleaseVariableType(kv.second);
    by_name_ = other.by_name_;
    tag_to_name_ = other.tag_to_name_;
    variables_ = other.variables_;
    variable_owner_ = other.variable_owner_;
    variable_tag_ = other.variable_tag_;
    vertex_tag_to_name_ = other.vertex_tag_to_name_;
  }
  return *this;
}

Registry::~Registry() {
  for (const auto& kv : variables_) internal::ReleaseVariableType(kv.second);
}

Registry::Registry() {
  RegisterVariable<SE2d>();
  RegisterVariable<SE3d>();
  RegisterVariable<Eigen::Vector2d>();
  RegisterVariable<Eigen::Vector3d>();
}

void Registry::CheckAgainstProbe(const FactorType& type) const {
  const auto refuse = [&](const std::string& field, const std::string& what) {
    throw InvalidArgument("cannot register factor type " + Owned(type) + ": " + field + " mismatch: " + what);
  };
  // A probe factor: keys 0..k-1, as measurement the identity of the last variable type whose
  // size is the measurement's (zeros where none is: a switchable pose-pose factor, keys pose,
  // pose, switch, gets the pose's identity), unit noise.
  const std::size_t n = type.variable_types.size();
  std::vector<Key> keys(n);
  for (std::size_t i = 0; i < n; ++i) keys[i] = i;
  // Zeros past measurement_size too: a factory that reads more than its type declares (a
  // plugin bug that reading a file would also hit) must not read past the probe's buffer.
  constexpr std::size_t kProbePadding = 64;
  std::vector<double> m(static_cast<std::size_t>(type.measurement_size) + kProbePadding, 0.0);
  for (std::size_t i = n; i-- > 0;) {
    if (AmbientDim(type.variable_types[i]) != type.measurement_size) continue;
    IdentityParams(type.variable_types[i], m.data());
    break;
  }
  std::unique_ptr<Factor> probe;
  try {
    probe = type.make(keys, m.data(), SqrtInformation::Identity(type.dim));
  } catch (const std::exception& e) {
    throw InvalidArgument(
        "cannot register factor type " + Owned(type) +
        ": its factory `make` threw on a probe factor (keys 0..k-1, the identity of the last variable type of "
        "the measurement's size as measurement, zeros where none is, unit noise): " +
        e.what() + "; `make` must accept the type's standard arguments");
  }
  if (!probe) {
    throw InvalidArgument("cannot register factor type " + Owned(type) + ": its factory `make` returned no factor");
  }
  if (probe->type_name() != type.name) {
    refuse("name", "the entry says '" + type.name + "' but its factors' type_name() is '" + probe->type_name() +
                       "'; make them the same (the writer finds a factor's type by that name)");
  }
  if (probe->residual_dim() != type.dim) {
    refuse("dimension", "the entry says " + std::to_string(type.dim) + " but its factors' residual_dim() is " +
                            std::to_string(probe->residual_dim()) + "; make them the same");
  }
  if (probe->variable_types() != type.variable_types) {
    refuse("variable types", "the entry says " + TypeList(type.variable_types) + " but its factors' variable_types() " +
                                 "are " + TypeList(probe->variable_types()) + "; make them the same");
  }
}

VarType Registry::RegisterVariable(const VariableType& type) {
  const auto refuse = [&](const std::string& what) {
    throw InvalidArgument("cannot register variable type '" + type.name + "' (owner '" + type.owner + "'): " + what);
  };
  if (variables_.count(type.name) != 0) {
    refuse("the name is taken already (owner '" + variable_owner_.at(type.name) + "'); choose another name");
  }
  if (!type.tag.empty()) {
    if (type.tag.find_first_of(" \t\r\n") != std::string::npos || type.tag[0] == '#') {
      refuse("the g2o tag '" + type.tag + "' contains blanks or starts with '#'; use one word");
    }
    const auto v = vertex_tag_to_name_.find(type.tag);
    if (v != vertex_tag_to_name_.end()) {
      refuse("the g2o tag '" + type.tag + "' is taken already by variable type '" + v->second + "' (owner '" +
             variable_owner_.at(v->second) + "'); choose another tag");
    }
    const auto f = tag_to_name_.find(type.tag);
    if (f != tag_to_name_.end()) {
      refuse("the g2o tag '" + type.tag + "' is taken already by factor type " + Owned(by_name_.at(f->second)) +
             "; choose another tag");
    }
  }
  const VarType id = InternVariableType(type);  // checks sizes and functions
  variables_.emplace(type.name, id);
  try {
    variable_owner_.emplace(type.name, type.owner);
    variable_tag_.emplace(type.name, type.tag);
    if (!type.tag.empty()) vertex_tag_to_name_.emplace(type.tag, type.name);
  } catch (...) {
    variables_.erase(type.name);
    variable_owner_.erase(type.name);
    variable_tag_.erase(type.name);
    throw;
  }
  internal::HoldVariableType(id);
  return id;
}

bool Registry::RemoveVariable(const std::string& name) {
  const auto it = variables_.find(name);
  if (it == variables_.end()) return false;
  const std::string& tag = variable_tag_.at(name);  // the tag registered here
  if (!tag.empty()) vertex_tag_to_name_.erase(tag);
  internal::ReleaseVariableType(it->second);
  variable_owner_.erase(name);
  variable_tag_.erase(name);
  variables_.erase(it);
  return true;
}

bool Registry::FindVariableByTag(const std::string& tag, VarType* type) const {
  const auto it = vertex_tag_to_name_.find(tag);
  if (it == vertex_tag_to_name_.end()) return false;
  *type = variables_.at(it->second);
  return true;
}

std::string Registry::VariableOwner(const std::string& name) const {
  const auto it = variable_owner_.find(name);
  return it == variable_owner_.end() ? std::string() : it->second;
}

bool Registry::Remove(const std::string& name) {
  const auto it = by_name_.find(name);
  if (it == by_name_.end()) return false;
  if (!it->second.tag.empty()) tag_to_name_.erase(it->second.tag);
  by_name_.erase(it);
  return true;
}

int Registry::RemoveOwner(const std::string& owner) {
  int removed = 0;
  for (auto it = by_name_.begin(); it != by_name_.end();) {
    if (it->second.owner == owner) {
      if (!it->second.tag.empty()) tag_to_name_.erase(it->second.tag);
      it = by_name_.erase(it);
      ++removed;
    } else {
      ++it;
    }
  }
  std::vector<std::string> variables;
  for (const auto& [name, who] : variable_owner_)
    if (who == owner) variables.push_back(name);
  for (const std::string& name : variables) removed += RemoveVariable(name) ? 1 : 0;
  return removed;
}

const FactorType* Registry::FindByTag(const std::string& tag) const {
  const auto it = tag_to_name_.find(tag);
  return it == tag_to_name_.end() ? nullptr : FindByName(it->second);
}

const FactorType* Registry::FindByName(const std::string& name) const {
  const auto it = by_name_.find(name);
  return it == by_name_.end() ? nullptr : &it->second;
}

namespace {

// A measurement that is a value of the factor's last variable type of its size (an SE3 edge's
// relative pose) is checked against that type's canonical form, so an edge quaternion far from
// unit length is warned about as a vertex's is (the factor normalises it).
void NoteCanonicalForm(const FactorType& type, const std::vector<double>& measurement, const Fields& f,
                       ReadContext& ctx) {
  for (auto it = type.variable_types.rbegin(); it != type.variable_types.rend(); ++it) {
    const VariableType& d = Describe(*it);
    if (d.ambient_dim != type.measurement_size) continue;
    if (d.canonicalize == nullptr) return;
    std::vector<double> copy = measurement;
    bool changed = false;
    try {
      changed = d.canonicalize(copy.data());
    } catch (const InvalidArgument&) {
      return;  // the factory says what is wrong, with the line
    }
    if (changed && ctx.canonicalized_measurements++ == 0) {
      ctx.first_canonicalized_line = f.line_number();
      ctx.canonicalize_note = d.canonicalize_note;
    }
    return;
  }
}

}  // namespace

std::unique_ptr<Factor> Registry::Read(const FactorType& type, const Fields& f, ReadContext& ctx) const {
  std::unique_ptr<Factor> factor;
  try {
    if (type.read) {
      factor = type.read(f, ctx);
    } else {
      if (!type.make) f.Fail("factor type '" + type.name + "' has no reader; its plugin must give `make` or `read`");
      // The layout text is only needed for the message.
      if (f.size() != type.StandardFieldCount() + 1) f.ExpectCount(type.StandardFieldCount(), StandardLayout(type));
      std::vector<Key> keys;
      keys.reserve(type.variable_types.size());
      std::size_t i = 1;
      for (std::size_t k = 0; k < type.variable_types.size(); ++k) keys.push_back(f.Id(i++));
      std::vector<double> measurement;
      measurement.reserve(type.measurement_size);
      for (int k = 0; k < type.measurement_size; ++k) measurement.push_back(f.Double(i++));
      NoteCanonicalForm(type, measurement, f, ctx);
      const SqrtInformation noise = ctx.ReadUpperInformation(f, i, type.dim);
      factor = type.make(std::move(keys), measurement.data(), noise);
    }
  } catch (const InvalidArgument& e) {
    // A factory rejected the values (for example a zero quaternion): say where.
    f.Fail(std::string(f.tag()) + ": " + e.what() + "; fix or remove the line");
  }
  if (!factor) f.Fail("the reader of factor type '" + type.name + "' returned no factor; this is a bug in its plugin");
  return factor;
}

std::string Registry::Write(const Factor& factor) const {
  std::string s;
  AppendLine(factor, &s);
  return s;
}

void Registry::AppendLine(const Factor& factor, std::string* line) const {
  const FactorType* type = FindByName(factor.type_name());
  if (!type) {
    throw InvalidArgument("cannot write a factor of type '" + factor.type_name() +
                          "': the type is not registered; load the plugin that defines it");
  }
  if (type->tag.empty()) {
    throw InvalidArgument("cannot write a factor of type '" + type->name +
                          "': it has no g2o tag, so g2o files cannot hold it");
  }
  if (type->write) {
    line->append(type->write(factor));
    return;
  }
  const std::vector<double> m = type->measurement ? type->measurement(factor) : factor.Measurement();
  if (static_cast<int>(m.size()) != type->measurement_size) {
    throw InvalidArgument("cannot write a factor of type '" + type->name + "': its measurement has " +
                          std::to_string(m.size()) + " numbers, the type declares " +
                          std::to_string(type->measurement_size));
  }
  line->append(type->tag);
  for (Key k : factor.keys()) {
    line->push_back(' ');
    AppendKey(line, k);
  }
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (!std::isfinite(m[i])) {
      throw InvalidArgument("cannot write a factor of type '" + type->name + "': measurement number " +
                            std::to_string(i) + " is not finite, and the file could not be read back");
    }
    line->push_back(' ');
    AppendDouble(line, m[i]);
  }
  // The information as the factor was given it (or R^T R), each entry the shortest text that
  // reads back as the same double: a file's own numbers come back as they were.
  const Eigen::MatrixXd info = factor.noise().Information();
  for (int i = 0; i < info.rows(); ++i) {
    for (int j = i; j < info.cols(); ++j) {
      line->push_back(' ');
      AppendDouble(line, info(i, j));
    }
  }
}

}  // namespace tether
