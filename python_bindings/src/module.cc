// The Python module `tether`: the entry point, tether's errors as Python exceptions, and the
// conversions every other part of the module shares.
#include <algorithm>
#include <string>
#include <vector>

#include "common.h"
#include "tether/core/version.h"
#include "tether/plugins/plugin_loader.h"
#include "tether/solvers/covariance.h"

namespace tether {
namespace python {

thread_local std::exception_ptr* PendingPythonError::current_ = nullptr;
std::mutex InUse::mutex_;
std::unordered_map<const void*, InUse::Use> InUse::uses_;

InUse::Scope::Scope(const void* object, const char* type, const char* by, Access access)
    : object_(object), access_(access) {
  Check(object, type, access);
  std::lock_guard<std::mutex> lock(mutex_);
  Use& u = uses_[object];
  if (access == Access::kWrite) {
    u.writer = true;
  } else {
    ++u.readers;
  }
  u.by = by;
}

InUse::Scope::~Scope() {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = uses_.find(object_);
  if (it == uses_.end()) return;
  if (access_ == Access::kWrite) {
    it->second.writer = false;
  } else {
    --it->second.readers;
  }
  if (!it->second.writer && it->second.readers == 0) uses_.erase(it);
}

void InUse::Check(const void* object, const char* type, Access access) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = uses_.find(object);
  if (it == uses_.end()) return;
  const Use& u = it->second;
  if (!u.writer && access == Access::kRead) return;
  throw InUseError(std::string("this ") + type + " is in use by a running " + u.by +
                   " (in another thread, or its own callback or Python factor); " +
                   (access == Access::kWrite ? "change" : "read") + " it after that call returns, or use a copy");
}

KeyArray CheckedKeys(const py::object& keys, const std::string& what) {
  const py::array a = py::array::ensure(keys);
  if (!a) {
    PyErr_Clear();
    throw InvalidArgument(what + " must be an array or sequence of integer keys");
  }
  const char kind = a.dtype().kind();
  if (a.size() > 0 && kind != 'i' && kind != 'u') {
    throw InvalidArgument(what + " must hold integer keys, got an array of dtype " + std::string(py::str(a.dtype())) +
                          " (a float key would be truncated)");
  }
  if (kind == 'i' && a.size() > 0) {
    const auto as_signed = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
    const std::int64_t* p = as_signed.data();
    for (py::ssize_t i = 0; i < as_signed.size(); ++i) {
      if (p[i] < 0) {
        throw InvalidArgument(what + "[" + std::to_string(i) + "] is " + std::to_string(p[i]) +
                              "; keys are never negative");
      }
    }
  }
  return KeyArray::ensure(a);
}

DoubleArray CopyToArray(const double* p, int n) {
  DoubleArray a(static_cast<py::ssize_t>(n));
  std::copy(p, p + n, a.mutable_data());
  return a;
}

VarType VarTypeByName(const std::string& name) {
  VarType t;
  if (FromString(name, &t)) return t;
  std::string known;
  for (int i = 0; i < kMaxVarTypes && IsKnown(static_cast<VarType>(i)); ++i) {
    known += (known.empty() ? "" : ", ") + std::string(ToString(static_cast<VarType>(i)));
  }
  throw InvalidArgument("unknown variable type '" + name + "'; known types: " + known +
                        " (a plugin's types are known once load_plugin has loaded it)");
}

py::object ToPython(VarType t, const double* p) {
  switch (t) {
    case VarType::kSE2:
      return py::cast(SE2d::FromParams(p));
    case VarType::kSE3:
      return py::cast(SE3d::FromParams(p));
    default:
      return CopyToArray(p, AmbientDim(t));
  }
}

void FromPython(VarType t, const py::handle& obj, double* out, const std::string& what) {
  if (t == VarType::kSE2 && py::isinstance<SE2d>(obj)) {
    obj.cast<const SE2d&>().ToParams(out);
    return;
  }
  if (t == VarType::kSE3 && py::isinstance<SE3d>(obj)) {
    obj.cast<const SE3d&>().ToParams(out);
    return;
  }
  const int n = AmbientDim(t);
  DoubleArray a;
  try {
    a = DoubleArray::ensure(obj);
  } catch (const py::error_already_set&) {
    a = DoubleArray();
  }
  if (!a || a.ndim() != 1 || a.shape(0) != n) {
    std::string got = a ? "an array of shape (" : "a " + std::string(py::str(obj.get_type().attr("__name__")));
    if (a) {
      for (py::ssize_t i = 0; i < a.ndim(); ++i) got += (i ? ", " : "") + std::to_string(a.shape(i));
      got += a.ndim() == 1 ? ",)" : ")";
    }
    throw InvalidArgument(what + ": a " + std::string(ToString(t)) + " is " +
                          (t == VarType::kSE2   ? "an SE2 or "
                           : t == VarType::kSE3 ? "an SE3 or "
                                                : "") +
                          "a float array of shape (" + std::to_string(n) + ",) (" + Describe(t).parameter_names +
                          "), got " + got);
  }
  std::copy(a.data(), a.data() + n, out);
  if (t == VarType::kSE2) out[2] = WrapAngle(out[2]);
}

namespace {

struct Part {
  int order;
  const char* name;
  ModulePart::Bind bind;
};
std::vector<Part>& Parts() {
  static std::vector<Part> parts;  // filled while the module's library is loaded
  return parts;
}

}  // namespace

ModulePart::ModulePart(int order, const char* name, Bind bind) { Parts().push_back({order, name, bind}); }

void ModulePart::BindAll(py::module_& m) {
  std::vector<Part> parts = Parts();
  std::sort(parts.begin(), parts.end(), [](const Part& a, const Part& b) {
    return a.order != b.order ? a.order < b.order : std::string(a.name) < b.name;
  });
  for (const Part& p : parts) p.bind(m);
}

namespace {

// The Python classes of tether's errors; created once, alive for the process.
struct ErrorTypes {
  py::handle error, parse, invalid, io, plugin, rank, in_use;
};
ErrorTypes& Types() {
  static ErrorTypes t;
  return t;
}

py::handle NewException(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  const std::string full = std::string("tether.") + name;
  py::dict dict;
  dict["__doc__"] = py::str(doc);
  PyObject* type = PyErr_NewException(full.c_str(), bases.ptr(), dict.ptr());
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(type));
  return py::handle(type);
}

}  // namespace

void BindErrors(py::module_& m) {
  ErrorTypes& t = Types();
  t.error =
      NewException(m, "Error", py::make_tuple(py::handle(PyExc_RuntimeError)),
                   "Base class of tether's errors (C++ tether::Error); the message says what, where and what to do.");
  t.parse = NewException(m, "ParseError", py::make_tuple(t.error, py::handle(PyExc_ValueError)),
                         "A file could not be read; the message starts with 'file:line:'.");
  t.invalid = NewException(m, "InvalidArgument", py::make_tuple(t.error, py::handle(PyExc_ValueError)),
                           "An argument or option was invalid (bad key, wrong type, wrong shape).");
  t.io = NewException(m, "IoError", py::make_tuple(t.error, py::handle(PyExc_OSError)),
                      "A file could not be opened, written or renamed.");
  t.plugin = NewException(m, "PluginError", py::make_tuple(t.error), "A plugin could not be loaded.");
  t.rank = NewException(m, "RankDeficientError", py::make_tuple(t.error),
                        "Marginals of a graph whose information matrix is singular.");
  t.in_use =
      NewException(m, "InUseError", py::make_tuple(t.error),
                   "The object is in use by a running call (optimize, a smoother's update or finish, MCL's update) in "
                   "another thread or in that call's own callback; see docs/python.md, 'Threads'.");
  py::register_exception_translator([](std::exception_ptr p) {
    const ErrorTypes& t = Types();
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ParseError& e) {
      PyErr_SetString(t.parse.ptr(), e.what());
    } catch (const InvalidArgument& e) {
      PyErr_SetString(t.invalid.ptr(), e.what());
    } catch (const IoError& e) {
      PyErr_SetString(t.io.ptr(), e.what());
    } catch (const PluginError& e) {
      PyErr_SetString(t.plugin.ptr(), e.what());
    } catch (const RankDeficientError& e) {
      PyErr_SetString(t.rank.ptr(), e.what());
    } catch (const InUseError& e) {
      PyErr_SetString(t.in_use.ptr(), e.what());
    } catch (const Error& e) {
      PyErr_SetString(t.error.ptr(), e.what());
    }
  });
}
TETHER_PYTHON_PART(0, BindErrors);

}  // namespace python
}  // namespace tether

PYBIND11_MODULE(tether, m) {
  namespace tp = tether::python;
  m.doc() =
      "tether: factor graphs for SLAM back-ends (poses SE2/SE3, points, built-in and plugin factors, "
      "Gauss-Newton / Levenberg-Marquardt / dog-leg over sparse Cholesky or QR, an incremental smoother, "
      "marginal covariances, EKF/UKF-SLAM front-ends). Arrays are float64 NumPy arrays; keys are ints.";
  m.attr("__version__") = TETHER_VERSION_STRING;
  tp::ModulePart::BindAll(m);
}
