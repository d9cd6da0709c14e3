// PythonFactor: a factor whose error (and optionally Jacobians) is a Python callable.
//
// The solver calls Evaluate with the GIL released (optimize releases it); Evaluate takes the GIL
// for the call. optimize and Marginals linearise a graph that holds a Python factor on the
// calling thread (HasPythonFactor), so that an exception it raises is kept for that call
// (PendingPythonError); a C++ caller with worker threads still gets a safe, serial call. The
// callables live in one shared, immutable holder, so copying the factor (graphs copy their
// factors) never touches a Python reference count without the GIL.
#include <cmath>

#include "common.h"
#include "tether/core/factor.h"

namespace tether {
namespace python {

namespace {

// The Python side of a PythonFactor, shared by its copies.
struct Callables {
  py::object error;
  py::object jacobians;  // None: central differences
  std::string name;
  double step = 1e-6;

  ~Callables() {
    if (!Py_IsInitialized()) {  // the interpreter is gone: the references go with it
      error.release();
      jacobians.release();
      return;
    }
    py::gil_scoped_acquire gil;
    error = py::object();
    jacobians = py::object();
  }
};

class PythonFactor : public Factor {
 public:
  PythonFactor(std::vector<Key> keys, std::vector<VarType> types, int dim, std::shared_ptr<const Callables> fns,
               SqrtInformation noise)
      : Factor(std::move(keys), std::move(noise)), types_(std::move(types)), dim_(dim), fns_(std::move(fns)) {}

  std::string type_name() const override { return fns_->name; }
  int residual_dim() const override { return dim_; }
  std::vector<VarType> variable_types() const override { return types_; }
  std::unique_ptr<Factor> Clone() const override { return std::make_unique<PythonFactor>(*this); }

  bool Evaluate(const double* const* params, double* error, double* const* jacobians) const override {
    py::gil_scoped_acquire gil;
    try {
      py::list vars(types_.size());
      for (std::size_t k = 0; k < types_.size(); ++k) vars[k] = ToPython(types_[k], params[k]);
      if (!CallError(vars, error)) return false;
      if (jacobians == nullptr) return true;
      if (!fns_->jacobians.is_none()) return CallJacobians(vars, jacobians);
      return NumericJacobians(params, error, jacobians);
    } catch (py::error_already_set&) {
      PendingPythonError::Keep();
      throw Error(Describe() + ": the Python callable raised an exception");
    } catch (const Error&) {
      // A result of the wrong shape or type: kept too, so that it is raised with its message
      // wherever the solve was started.
      PendingPythonError::Keep();
      throw;
    }
  }

 private:
  // Calls the error callable; false where it returned non-finite numbers.
  bool CallError(const py::list& vars, double* out) const {
    const py::object r = fns_->error(vars);
    CopyVector(r, out, "error");
    for (int i = 0; i < dim_; ++i) {
      if (!std::isfinite(out[i])) return false;
    }
    return true;
  }

  void CopyVector(const py::object& r, double* out, const char* what) const {
    DoubleArray a = DoubleArray::ensure(r);
    if (!a || a.size() != dim_ || a.ndim() > 1) {
      throw InvalidArgument(Describe() + ": the " + what + " callable must return " + std::to_string(dim_) +
                            " numbers (a float array of shape (" + std::to_string(dim_) + ",)), got " +
                            std::string(py::str(py::repr(r))).substr(0, 80));
    }
    std::copy(a.data(), a.data() + dim_, out);
  }

  bool CallJacobians(const py::list& vars, double* const* jacobians) const {
    const py::object r = fns_->jacobians(vars);
    if (!py::isinstance<py::sequence>(r) || py::len(r) != types_.size()) {
      throw InvalidArgument(Describe() + ": the jacobians callable must return a list of " +
                            std::to_string(types_.size()) + " arrays, one (" + std::to_string(dim_) +
                            ", tangent) array per key");
    }
    const py::sequence seq = r.cast<py::sequence>();
    for (std::size_t k = 0; k < types_.size(); ++k) {
      if (jacobians[k] == nullptr) continue;
      const int cols = TangentDim(types_[k]);
      DoubleArray a = DoubleArray::ensure(seq[k]);
      if (!a || a.ndim() != 2 || a.shape(0) != dim_ || a.shape(1) != cols) {
        throw InvalidArgument(Describe() + ": Jacobian " + std::to_string(k) + " must have shape (" +
                              std::to_string(dim_) + ", " + std::to_string(cols) + ")");
      }
      std::copy(a.data(), a.data() + dim_ * cols, jacobians[k]);  // both row-major
      for (int i = 0; i < dim_ * cols; ++i) {
        if (!std::isfinite(jacobians[k][i])) return false;
      }
    }
    return true;
  }

  // Central differences along each tangent direction of each key: J[:, c] = (e(x [+] h u_c) -
  // e(x [-] h u_c)) / 2h.
  bool NumericJacobians(const double* const* params, const double* error, double* const* jacobians) const {
    (void)error;
    const double h = fns_->step;
    std::vector<double> plus(static_cast<std::size_t>(dim_)), minus(plus.size());
    for (std::size_t k = 0; k < types_.size(); ++k) {
      if (jacobians[k] == nullptr) continue;
      const VarType t = types_[k];
      const int cols = TangentDim(t);
      std::vector<double> delta(static_cast<std::size_t>(cols), 0.0);
      std::vector<double> moved(static_cast<std::size_t>(AmbientDim(t)));
      py::list vars(types_.size());
      for (std::size_t q = 0; q < types_.size(); ++q) vars[q] = ToPython(types_[q], params[q]);
      for (int c = 0; c < cols; ++c) {
        delta[static_cast<std::size_t>(c)] = h;
        RetractParams<double>(t, params[k], delta.data(), moved.data());
        vars[k] = ToPython(t, moved.data());
        if (!CallError(vars, plus.data())) return false;
        delta[static_cast<std::size_t>(c)] = -h;
        RetractParams<double>(t, params[k], delta.data(), moved.data());
        vars[k] = ToPython(t, moved.data());
        if (!CallError(vars, minus.data())) return false;
        delta[static_cast<std::size_t>(c)] = 0;
        for (int i = 0; i < dim_; ++i) jacobians[k][i * cols + c] = (plus[i] - minus[i]) / (2 * h);
      }
    }
    return true;
  }

  std::vector<VarType> types_;
  int dim_;
  std::shared_ptr<const Callables> fns_;
};

}  // namespace

bool HasPythonFactor(const FactorGraph& graph) {
  for (const auto& f : graph.factors()) {
    if (dynamic_cast<const PythonFactor*>(f.get()) != nullptr) return true;
  }
  return false;
}

void BindPythonFactor(py::module_& m) {
  py::class_<PythonFactor, Factor, std::shared_ptr<PythonFactor>>(
      m, "PythonFactor",
      "A factor written in Python. error(variables) returns the error, a float array (dim,); variables is "
      "a list with one entry per key: SE2, SE3, a (2,) or (3,) array for points, the parameter array for "
      "other types. jacobians(variables), where given, returns one (dim, tangent) array per key (the "
      "derivative along the box-plus step, see SE2.retract / SE3.retract); without it, central differences "
      "with step `step` are used. Usable in any graph next to C++ factors; optimize() takes the GIL for "
      "each call.")
      .def(py::init([](std::vector<Key> keys, const std::vector<std::string>& types, int dim, py::object error,
                       SqrtInformation noise, py::object jacobians, std::string name, double step) {
             if (keys.empty() || keys.size() != types.size()) {
               throw InvalidArgument("PythonFactor: one variable type per key is needed; got " +
                                     std::to_string(keys.size()) + " keys and " + std::to_string(types.size()) +
                                     " types");
             }
             if (dim < 1) throw InvalidArgument("PythonFactor: dim must be at least 1, got " + std::to_string(dim));
             if (noise.dim() != dim) {
               throw InvalidArgument("PythonFactor: the noise model has dimension " + std::to_string(noise.dim()) +
                                     ", the error " + std::to_string(dim));
             }
             if (!PyCallable_Check(error.ptr())) throw InvalidArgument("PythonFactor: error must be callable");
             if (!jacobians.is_none() && !PyCallable_Check(jacobians.ptr())) {
               throw InvalidArgument("PythonFactor: jacobians must be callable or None");
             }
             if (!(step > 0) || !std::isfinite(step)) {
               throw InvalidArgument("PythonFactor: step must be a finite number above 0");
             }
             std::vector<VarType> vt;
             for (const std::string& t : types) vt.push_back(VarTypeByName(t));
             auto fns = std::make_shared<Callables>();
             fns->error = std::move(error);
             fns->jacobians = std::move(jacobians);
             fns->name = std::move(name);
             fns->step = step;
             return std::make_shared<PythonFactor>(std::move(keys), std::move(vt), dim, std::move(fns),
                                                   std::move(noise));
           }),
           py::arg("keys"), py::arg("types"), py::arg("dim"), py::arg("error"), py::arg("noise"),
           py::arg("jacobians") = py::none(), py::arg("name") = "PythonFactor", py::arg("step") = 1e-6);
}
TETHER_PYTHON_PART(30, BindPythonFactor);

}  // namespace python
}  // namespace tether
