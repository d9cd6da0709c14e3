#pragma once
// Shared pieces of the Python module: conversions between NumPy arrays and tether's types,
// the error a Python callable raised inside a C++ call, and the Bind* functions each
// translation unit defines.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <exception>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>

#include "tether/core/error.h"
#include "tether/core/factor_graph.h"
#include "tether/core/se2.h"
#include "tether/core/values.h"
#include "tether/core/variable.h"

namespace tether {
namespace lidar {
struct LaserScan;
}
namespace python {

namespace py = pybind11;

/// A C-contiguous float64 array (NumPy converts other dtypes and layouts on the way in).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
/// A C-contiguous uint64 array, for keys.
using KeyArray = py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast>;

/// `a` as keys: an array (or sequence) of integers, none negative; anything else (floats that
/// would be truncated, -1 that would wrap) throws InvalidArgument naming `what`.
KeyArray CheckedKeys(const py::object& keys, const std::string& what);
/// A 1-D float64 array holding a copy of n doubles.
DoubleArray CopyToArray(const double* p, int n);
/// The variable of type `t` with parameters `p` as Python sees it: SE2, SE3, a (2,) or (3,)
/// array for points, the (ambient,) parameter array for other (registered) types.
py::object ToPython(VarType t, const double* p);
/// The parameters of `obj` as a variable of type `t` (throws InvalidArgument naming `what`).
void FromPython(VarType t, const py::handle& obj, double* out, const std::string& what);
/// The variable type of that name; throws InvalidArgument listing the known names.
VarType VarTypeByName(const std::string& name);

/// The first Python exception raised by a callable that C++ code called (a Python factor, an
/// iteration callback), kept for the call that ran that C++ code. The C++ code sees a
/// tether::Error and unwinds; the binding that made the C++ call raises the original Python
/// exception. Each call keeps its own (a Scope on the calling thread, nested calls each theirs),
/// so two threads whose callables raise at once each get their own exception; Python factors
/// run on the calling thread (HasPythonFactor: optimize and Marginals do not spread a graph that
/// holds one over worker threads).
class PendingPythonError {
 public:
  /// The slot of one call, on the thread that makes it; the slot in use until it is destroyed.
  class Scope {
   public:
    Scope() : outer_(current_) { current_ = &error_; }
    ~Scope() { current_ = outer_; }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;
    /// Rethrows the kept exception, if any (with the GIL held).
    void RethrowIfAny() {
      std::exception_ptr e;
      e.swap(error_);
      if (e) std::rethrow_exception(e);
    }

   private:
    std::exception_ptr error_;
    std::exception_ptr* outer_;
  };
  /// Keeps the exception being handled for the call running on this thread (call inside a
  /// catch block, with the GIL held). Outside any call nothing is kept: the C++ error that
  /// follows says what happened.
  static void Keep() {
    if (current_ != nullptr && !*current_) *current_ = std::current_exception();
  }

 private:
  static thread_local std::exception_ptr* current_;
};

/// True where `graph` holds a factor written in Python (python_factor.cc).
bool HasPythonFactor(const FactorGraph& graph);

/// Runs f (a C++ call that may call Python callables) and raises the first Python exception
/// those raised, in preference to the C++ error it caused.
template <class F>
auto Guarded(F&& f) -> decltype(f()) {
  PendingPythonError::Scope scope;
  try {
    if constexpr (std::is_void_v<decltype(f())>) {
      f();
      scope.RethrowIfAny();
    } else {
      auto result = f();
      scope.RethrowIfAny();
      return result;
    }
  } catch (...) {
    scope.RethrowIfAny();
    throw;
  }
}

/// Raised (as tether.InUseError) by a call on an object a running call is using.
class InUseError : public Error {
 public:
  using Error::Error;
};

/// The objects a call that releases the GIL is using (optimize reads a graph and writes its
/// values; a smoother's update or finish writes the smoother). Any other call on such an
/// object -- from another thread, or from a callback or Python factor of that very call --
/// raises InUseError instead of racing it: reading is refused where the running call writes,
/// writing wherever a running call uses the object. Every access is made with the GIL held.
class InUse {
 public:
  enum class Access { kRead, kWrite };

  /// Marks `object` used by the call `by` ("optimize", "IncrementalSmoother.update") for the
  /// scope's lifetime; throws InUseError where another call's use conflicts with it.
  class Scope {
   public:
    Scope(const void* object, const char* type, const char* by, Access access);
    ~Scope();
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    const void* object_;
    Access access_;
  };

  /// Throws InUseError where a running call's use of `object` conflicts with `access`.
  static void Check(const void* object, const char* type, Access access);

 private:
  struct Use {
    int readers = 0;
    bool writer = false;
    std::string by;
  };
  static std::mutex mutex_;
  static std::unordered_map<const void*, Use> uses_;
};

/// A bound member function that first checks the object is not in use (InUse::Check).
template <class C, class R, class... A>
auto Writes(R (C::*f)(A...), const char* type) {
  return [f, type](C& c, A... a) -> R {
    InUse::Check(&c, type, InUse::Access::kWrite);
    return (c.*f)(std::forward<A>(a)...);
  };
}
template <class C, class R, class... A>
auto Reads(R (C::*f)(A...) const, const char* type) {
  return [f, type](const C& c, A... a) -> R {
    InUse::Check(&c, type, InUse::Access::kRead);
    return (c.*f)(std::forward<A>(a)...);
  };
}

/// A pose (x, y, theta) from an SE2, a tuple, list or array of three numbers; throws
/// InvalidArgument naming `what` for anything else or a pose lidar::PoseProblem refuses.
SE2d PoseFromTuple(const py::handle& h, const char* what);
/// A scan from arrays (lidar.cc): ranges (N,) [m], beam i at angle_min + i angle_increment, the
/// stamp, the range limits, the odometry pose (None: none) and the laser's pose on the robot
/// (None: the robot's centre). Throws InvalidArgument for what cannot make a scan.
lidar::LaserScan MakeScan(const DoubleArray& ranges, double angle_min, double angle_increment, double stamp,
                          double range_min, double range_max, const py::object& odometry,
                          const py::object& laser_offset);

/// One part of the module: each binding file adds its part with one line after its bind
/// function,
///   TETHER_PYTHON_PART(80, BindLocalization);
/// and module.cc binds every part in the order of the numbers (a part whose classes another
/// part uses as base classes or default arguments comes first; the built-in parts use 0-80).
/// So a new front-end's binding is its own file and nothing else (the build takes every file
/// in python_bindings/src).
class ModulePart {
 public:
  using Bind = void (*)(py::module_&);
  ModulePart(int order, const char* name, Bind bind);
  /// Binds every part into `m`, in order (equal numbers by name).
  static void BindAll(py::module_& m);
};
#define TETHER_PYTHON_PART(order, bind) static const ::tether::python::ModulePart kModulePart##bind(order, #bind, &bind)

}  // namespace python
}  // namespace tether
