// Noise models, robust losses, Values, the built-in factors and FactorGraph (with batch
// construction from NumPy arrays).
#include <optional>
#include <sstream>
#include <unordered_set>

#include "common.h"
#include "tether/core/factor_graph.h"
#include "tether/core/robust_kernels.h"
#include "tether/factors/between_se2.h"
#include "tether/factors/between_se3.h"
#include "tether/factors/builtin.h"
#include "tether/factors/pose_point.h"
#include "tether/factors/prior.h"
#include "tether/factors/range_bearing.h"
#include "tether/factors/switchable.h"

namespace tether {
namespace python {

namespace {

using FactorPtr = std::shared_ptr<Factor>;
using LossPtr = std::shared_ptr<LossFunction>;

std::string ShapeText(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// Throws InvalidArgument unless `a` has the shape `want` (-1: any length, the same in every
// -1 place is checked by the caller).
void ExpectShape(const py::array& a, std::initializer_list<py::ssize_t> want, const std::string& what) {
  bool ok = a.ndim() == static_cast<py::ssize_t>(want.size());
  std::string text = "(";
  int i = 0;
  for (py::ssize_t w : want) {
    if (ok && w >= 0 && a.shape(i) != w) ok = false;
    text += (i ? ", " : "") + (w < 0 ? std::string("N") : std::to_string(w));
    ++i;
  }
  text += want.size() == 1 ? ",)" : ")";
  if (!ok) throw InvalidArgument(what + " must have shape " + text + ", got " + ShapeText(a));
}

// The loss of a Python argument: None (no loss), a LossFunction, or a text form "huber:1".
std::shared_ptr<const LossFunction> LossFrom(const py::object& o) {
  if (o.is_none()) return nullptr;
  if (py::isinstance<py::str>(o)) return MakeLoss(o.cast<std::string>());
  return o.cast<LossPtr>();
}

py::tuple Evaluated(const Factor& f, const Values& values, bool whiten) {
  const std::vector<const double*> params = f.GatherParams(values);
  const int d = f.residual_dim();
  if (whiten && d != f.dim()) {
    throw InvalidArgument(f.Describe() + ": the noise model has dimension " + std::to_string(f.dim()) + ", the error " +
                          std::to_string(d));
  }
  Eigen::VectorXd e(d);
  std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jac;
  std::vector<double*> jp;
  const std::vector<VarType> types = f.variable_types();
  for (VarType t : types) jac.emplace_back(d, TangentDim(t));
  for (auto& j : jac) jp.push_back(j.data());
  const bool ok =
      whiten ? f.Linearize(params.data(), e.data(), jp.data()) : f.Evaluate(params.data(), e.data(), jp.data());
  if (!ok) throw InvalidArgument(f.Describe() + ": cannot be evaluated at these values");
  py::list js;
  for (auto& j : jac) js.append(py::cast(Eigen::MatrixXd(j)));
  return py::make_tuple(e, js);
}

// Noise models of a batch: one (d, d) information matrix for every row, or one per row (N, d, d).
std::vector<SqrtInformation> BatchNoise(const DoubleArray& info, py::ssize_t n, int d) {
  std::vector<SqrtInformation> out;
  const py::ssize_t dd = d;
  if (info.ndim() == 2) {
    ExpectShape(info, {dd, dd}, "information");
    out.push_back(SqrtInformation::FromInformation(Eigen::Map<const Eigen::MatrixXd>(info.data(), d, d)));
    return out;
  }
  ExpectShape(info, {n, dd, dd}, "information");
  out.reserve(static_cast<std::size_t>(n));
  const double* p = info.data();
  for (py::ssize_t r = 0; r < n; ++r) {
    try {
      out.push_back(SqrtInformation::FromInformation(Eigen::Map<const Eigen::MatrixXd>(p + r * d * d, d, d)));
    } catch (const Error& e) {
      throw InvalidArgument("information[" + std::to_string(r) + "]: " + e.what());
    }
  }
  return out;
}

// Adds rows i[n], j[n], z[n] (width `width`), information as BatchNoise, with make(i, j, z,
// noise) building each factor; all or nothing. Returns the handles.
template <class Make>
py::array_t<std::uint64_t> AddBatch(FactorGraph& g, const py::object& i_in, const py::object& j_in,
                                    const DoubleArray& z, const DoubleArray& info, int width, int d, Make make) {
  InUse::Check(&g, "FactorGraph", InUse::Access::kWrite);
  const KeyArray ki = CheckedKeys(i_in, "i");
  const KeyArray kj = CheckedKeys(j_in, "j");
  ExpectShape(ki, {-1}, "i");
  const py::ssize_t n = ki.shape(0);
  ExpectShape(kj, {n}, "j");
  ExpectShape(z, {n, width}, "z");
  const std::vector<SqrtInformation> noise = BatchNoise(info, n, d);
  std::vector<std::unique_ptr<Factor>> made(static_cast<std::size_t>(n));
  {
    py::gil_scoped_release release;
    const std::uint64_t* pi = ki.data();
    const std::uint64_t* pj = kj.data();
    const double* pz = z.data();
    for (py::ssize_t r = 0; r < n; ++r) {
      for (int c = 0; c < width; ++c) {
        if (!std::isfinite(pz[r * width + c])) {
          throw InvalidArgument("z[" + std::to_string(r) + "] is not finite; every measurement must be");
        }
      }
      if (pi[r] == pj[r]) {
        throw InvalidArgument("row " + std::to_string(r) + " connects " + KeyToString(pi[r]) +
                              " to itself; a factor's keys must be distinct");
      }
      made[static_cast<std::size_t>(r)] =
          make(pi[r], pj[r], pz + r * width, noise[noise.size() == 1 ? 0 : static_cast<std::size_t>(r)]);
    }
  }
  py::array_t<std::uint64_t> handles(n);
  std::uint64_t* h = handles.mutable_data();
  for (py::ssize_t r = 0; r < n; ++r) h[r] = g.Add(std::move(made[static_cast<std::size_t>(r)]));
  return handles;
}

Values CopiedValues(const Values& v) {
  InUse::Check(&v, "Values", InUse::Access::kRead);
  return v;
}

FactorGraph CopiedGraph(const FactorGraph& g) {
  InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
  return g;
}

void BindNoiseAndLosses(py::module_& m) {
  py::class_<SqrtInformation>(m, "SqrtInformation",
                              "A Gaussian noise model kept as the square root R of its information matrix "
                              "(R^T R = information); factors minimise |R e|^2.")
      .def_static("from_information", &SqrtInformation::FromInformation, py::arg("information"),
                  "From an (n, n) symmetric positive definite information matrix (the inverse covariance).")
      .def_static(
          "from_covariance",
          [](const Eigen::MatrixXd& cov) {
            if (cov.rows() != cov.cols() || cov.rows() == 0) {
              throw InvalidArgument("a covariance must be a square, non-empty matrix; got " +
                                    std::to_string(cov.rows()) + " x " + std::to_string(cov.cols()));
            }
            return SqrtInformation::FromInformation(cov.inverse());
          },
          py::arg("covariance"), "From an (n, n) covariance matrix.")
      .def_static("from_sigmas", &SqrtInformation::FromSigmas, py::arg("sigmas"), "From (n,) standard deviations.")
      .def_static("identity", &SqrtInformation::Identity, py::arg("dim"))
      .def_static("isotropic", &SqrtInformation::Isotropic, py::arg("dim"), py::arg("sigma"))
      .def_property_readonly("dim", &SqrtInformation::dim)
      .def("information", &SqrtInformation::Information, "(n, n)")
      .def("R", &SqrtInformation::R, "(n, n), upper triangular")
      .def("__repr__", [](const SqrtInformation& s) { return "SqrtInformation(dim=" + std::to_string(s.dim()) + ")"; });

  py::class_<LossFunction, LossPtr>(m, "LossFunction",
                                    "A robust loss rho(s) on a factor's squared whitened error s = |R e|^2.")
      .def_property_readonly("name", &LossFunction::name)
      .def(
          "evaluate",
          [](const LossFunction& l, double s) {
            double rho[3];
            l.Evaluate(s, rho);
            return py::make_tuple(rho[0], rho[1], rho[2]);
          },
          py::arg("s"), "(rho(s), rho'(s), rho''(s))")
      .def(
          "weight", [](const LossFunction& l, double s) { return RobustWeight(&l, s); }, py::arg("s"),
          "sqrt(rho'(s)), the weight the solvers apply to the whitened residual and Jacobians")
      .def("__repr__", [](const LossFunction& l) { return "LossFunction('" + l.name() + "')"; });
  py::class_<HuberLoss, LossFunction, std::shared_ptr<HuberLoss>>(m, "HuberLoss")
      .def(py::init<double>(), py::arg("delta"));
  py::class_<CauchyLoss, LossFunction, std::shared_ptr<CauchyLoss>>(m, "CauchyLoss")
      .def(py::init<double>(), py::arg("c"));
  py::class_<TukeyLoss, LossFunction, std::shared_ptr<TukeyLoss>>(m, "TukeyLoss").def(py::init<double>(), py::arg("c"));
  py::class_<GemanMcClureLoss, LossFunction, std::shared_ptr<GemanMcClureLoss>>(m, "GemanMcClureLoss")
      .def(py::init<double>(), py::arg("c"));
  py::class_<DcsLoss, LossFunction, std::shared_ptr<DcsLoss>>(m, "DcsLoss").def(py::init<double>(), py::arg("phi"));
  m.def(
      "make_loss", [](const std::string& spec) { return std::const_pointer_cast<LossFunction>(MakeLoss(spec)); },
      py::arg("spec"),
      "A loss from its text form NAME:SCALE (NAME:SCALE:PARAM for a loss with a parameter), NAME looked up in "
      "the loss registry (loss_names()): huber:1, cauchy:2, tukey:4.685, gm:1, dcs:1, or a loaded plugin's, "
      "e.g. barron:1:0.5. Raises ValueError listing the registered names for an unknown one.");
  m.def("loss_names", &RegisteredLossNames,
        "The names make_loss, loss= arguments and robust= rules accept, in the order they were registered: the "
        "built-in losses, then those of the plugins loaded (load_plugin).");
}

void BindValues(py::module_& m) {
  py::class_<Values>(m, "Values",
                     "The variables of a problem by key: SE2, SE3, points as float arrays (2,) / (3,), and "
                     "registered types (plugins) as their parameter arrays.")
      .def(py::init<>())
      .def("copy", [](const Values& v) { return CopiedValues(v); })
      .def("__copy__", [](const Values& v) { return CopiedValues(v); })
      .def("__deepcopy__", [](const Values& v, py::dict) { return CopiedValues(v); })
      .def(
          "insert",
          [](Values& v, Key k, const py::object& value, const std::optional<std::string>& type) {
            InUse::Check(&v, "Values", InUse::Access::kWrite);
            VarType t;
            if (type) {
              t = VarTypeByName(*type);
            } else if (py::isinstance<SE2d>(value)) {
              t = VarType::kSE2;
            } else if (py::isinstance<SE3d>(value)) {
              t = VarType::kSE3;
            } else {
              // Three plain numbers may be an SE2's (x, y, theta) as well as a Point3: the caller
              // says which. A NumPy array of shape (3,) is a point.
              if ((py::isinstance<py::tuple>(value) || py::isinstance<py::list>(value)) && py::len(value) == 3) {
                throw InvalidArgument("insert(" + KeyToString(k) +
                                      "): three numbers in a tuple or list may be an SE2's (x, y, theta) or a "
                                      "Point3; pass tether.SE2(x, y, theta), a NumPy array for a point, or "
                                      "type='SE2' / type='Point3'");
              }
              const DoubleArray a = DoubleArray::ensure(value);
              if (!a || a.ndim() != 1 || (a.shape(0) != 2 && a.shape(0) != 3)) {
                throw InvalidArgument("insert(" + KeyToString(k) +
                                      "): the value must be an SE2, an SE3, a point of shape (2,) or (3,), or "
                                      "parameters with type='name'");
              }
              t = a.shape(0) == 2 ? VarType::kPoint2 : VarType::kPoint3;
            }
            std::vector<double> p(static_cast<std::size_t>(AmbientDim(t)));
            FromPython(t, value, p.data(), "insert(" + KeyToString(k) + ")");
            v.InsertParams(k, t, p.data());
          },
          py::arg("key"), py::arg("value"), py::arg("type") = py::none(),
          "Inserts a new variable; type names a registered type for a parameter array (e.g. 'Switch').")
      .def(
          "update",
          [](Values& v, Key k, const py::object& value) {
            InUse::Check(&v, "Values", InUse::Access::kWrite);
            if (!v.Has(k)) throw InvalidArgument("update: there is no variable " + KeyToString(k));
            FromPython(v.TypeOf(k), value, v.Params(k), "update(" + KeyToString(k) + ")");
          },
          py::arg("key"), py::arg("value"), "Replaces the value of an existing variable (same type).")
      .def(
          "at",
          [](const Values& v, Key k) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            if (!v.Has(k)) throw InvalidArgument("there is no variable " + KeyToString(k));
            return ToPython(v.TypeOf(k), v.Params(k));
          },
          py::arg("key"))
      .def("__getitem__",
           [](const Values& v, Key k) {
             InUse::Check(&v, "Values", InUse::Access::kRead);
             if (!v.Has(k)) throw py::key_error("no variable " + KeyToString(k));
             return ToPython(v.TypeOf(k), v.Params(k));
           })
      .def("erase", Writes(&Values::Erase, "Values"), py::arg("key"), "Removes a variable; False where there is none.")
      .def("has", Reads(&Values::Has, "Values"), py::arg("key"))
      .def("__contains__", Reads(&Values::Has, "Values"))
      .def("__len__", Reads(&Values::size, "Values"))
      .def("keys", Reads(&Values::keys, "Values"), "Keys in insertion order.")
      .def(
          "type_of",
          [](const Values& v, Key k) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            if (!v.Has(k)) throw InvalidArgument("there is no variable " + KeyToString(k));
            return std::string(ToString(v.TypeOf(k)));
          },
          py::arg("key"))
      .def(
          "params",
          [](const Values& v, Key k) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            if (!v.Has(k)) throw InvalidArgument("there is no variable " + KeyToString(k));
            return CopyToArray(v.Params(k), AmbientDim(v.TypeOf(k)));
          },
          py::arg("key"), "The raw parameters (variable.h layouts: SE2 x y theta, SE3 x y z qx qy qz qw).")
      .def(
          "insert_batch",
          [](Values& v, const std::string& type, const py::object& keys_in, const DoubleArray& params) {
            InUse::Check(&v, "Values", InUse::Access::kWrite);
            const KeyArray keys = CheckedKeys(keys_in, "keys");
            const VarType t = VarTypeByName(type);
            const py::ssize_t a = AmbientDim(t);
            ExpectShape(keys, {-1}, "keys");
            ExpectShape(params, {keys.shape(0), a}, "params");
            const std::uint64_t* k = keys.data();
            std::unordered_set<Key> seen;
            for (py::ssize_t r = 0; r < keys.shape(0); ++r) {
              if (v.Has(k[r])) throw InvalidArgument("insert_batch: key " + KeyToString(k[r]) + " exists already");
              if (!seen.insert(k[r]).second) {
                throw InvalidArgument("insert_batch: key " + KeyToString(k[r]) + " is given twice");
              }
            }
            std::vector<double> p(static_cast<std::size_t>(a));
            for (py::ssize_t r = 0; r < keys.shape(0); ++r) {
              std::copy(params.data() + r * a, params.data() + (r + 1) * a, p.begin());
              if (t == VarType::kSE2) p[2] = WrapAngle(p[2]);
              v.InsertParams(k[r], t, p.data());
            }
          },
          py::arg("type"), py::arg("keys"), py::arg("params"),
          "Inserts N variables of one type: keys (N,) uint64, params (N, ambient) float64.")
      .def(
          "array",
          [](const Values& v, const std::string& type) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            const VarType t = VarTypeByName(type);
            const py::ssize_t n = static_cast<py::ssize_t>(v.Count(t)), a = AmbientDim(t);
            py::array_t<std::uint64_t> keys(n);
            DoubleArray params({n, a});
            if (n > 0) {
              std::uint64_t* k = keys.mutable_data();
              for (Key key : v.keys()) {
                if (v.TypeOf(key) == t) *k++ = key;
              }
              const std::vector<double>& d = v.Data(t);
              std::copy(d.begin(), d.end(), params.mutable_data());
            }
            return py::make_tuple(keys, params);
          },
          py::arg("type"),
          "(keys (N,) uint64, params (N, ambient) float64) of every variable of one type, in insertion order.")
      .def(
          "retract",
          [](Values& v, Key k, const Eigen::VectorXd& delta) {
            InUse::Check(&v, "Values", InUse::Access::kWrite);
            if (!v.Has(k)) throw InvalidArgument("there is no variable " + KeyToString(k));
            if (delta.size() != TangentDim(v.TypeOf(k))) {
              throw InvalidArgument("retract(" + KeyToString(k) + "): a " + std::string(ToString(v.TypeOf(k))) +
                                    " step has " + std::to_string(TangentDim(v.TypeOf(k))) + " entries, got " +
                                    std::to_string(delta.size()));
            }
            v.Retract(k, delta.data());
          },
          py::arg("key"), py::arg("delta"), "Box-plus in place.")
      .def("__repr__", [](const Values& v) {
        InUse::Check(&v, "Values", InUse::Access::kRead);
        if (v.size() > 20) return "Values(" + std::to_string(v.size()) + " variables)";
        std::ostringstream s;
        s << v;
        return "Values(\n" + s.str() + ")";
      });
}

void BindFactors(py::module_& m) {
  py::class_<Factor, FactorPtr>(m, "Factor",
                                "A measurement over a few variables. Graphs hold their own copies: "
                                "graph.add(f) copies f, graph[i] returns a copy.")
      .def_property_readonly("type_name", &Factor::type_name)
      .def_property_readonly("keys", &Factor::keys)
      .def_property_readonly("dim", &Factor::dim)
      .def_property_readonly("variable_types",
                             [](const Factor& f) {
                               std::vector<std::string> names;
                               for (VarType t : f.variable_types()) names.emplace_back(ToString(t));
                               return names;
                             })
      .def("measurement", &Factor::Measurement, "The measurement in the type's file layout, as a list of numbers.")
      .def_property_readonly(
          "measured",
          [](const Factor& f) -> py::object {
            const std::vector<double> z = f.Measurement();
            const FactorType* t = DefaultRegistry().FindByName(f.type_name());
            VarType type;
            if (t != nullptr && MeasurementIsAValue(*t, &type) && static_cast<int>(z.size()) == AmbientDim(type)) {
              return ToPython(type, z.data());
            }
            return CopyToArray(z.data(), static_cast<int>(z.size()));
          },
          "The measurement as a value: an SE2 or SE3 where it is a relative pose or a pose prior (so "
          "x_i * f.measured predicts x_j), a point array where it is a point; otherwise the numbers of its file "
          "layout as an array.")
      .def_property("noise", &Factor::noise, &Factor::set_noise)
      .def_property(
          "loss", [](const Factor& f) { return std::const_pointer_cast<LossFunction>(f.shared_loss()); },
          [](Factor& f, const py::object& o) { f.set_loss(LossFrom(o)); })
      .def(
          "set_loss", [](Factor& f, const py::object& o) { f.set_loss(LossFrom(o)); }, py::arg("loss"),
          "A LossFunction, its text form ('huber:1') or None.")
      .def_property("loop_closure", &Factor::loop_closure, &Factor::set_loop_closure)
      .def(
          "chi2",
          [](const Factor& f, const Values& v) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return f.Chi2(v); });
          },
          py::arg("values"))
      .def(
          "cost",
          [](const Factor& f, const Values& v) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return f.Cost(v); });
          },
          py::arg("values"))
      .def(
          "evaluate",
          [](const Factor& f, const Values& v) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return Evaluated(f, v, false); });
          },
          py::arg("values"), "(error (d,), [Jacobian (d, tangent) per key]) without whitening.")
      .def(
          "linearize",
          [](const Factor& f, const Values& v) {
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return Evaluated(f, v, true); });
          },
          py::arg("values"), "(R e, [R J per key]): whitened, as the solver sees it (without the loss).")
      .def("copy", [](const Factor& f) { return FactorPtr(f.Clone()); })
      .def("__repr__", [](const Factor& f) { return "<" + f.Describe() + ">"; });

  py::class_<BetweenSE2, Factor, std::shared_ptr<BetweenSE2>>(m, "BetweenSE2", "e = z.local(x_i^-1 x_j) (3,).")
      .def(py::init<Key, Key, const SE2d&, SqrtInformation>(), py::arg("i"), py::arg("j"), py::arg("z"),
           py::arg("noise"))
      .def_property_readonly("measured", &BetweenSE2::measured);
  py::class_<BetweenSE3, Factor, std::shared_ptr<BetweenSE3>>(m, "BetweenSE3", "Relative 3D pose (6,).")
      .def(py::init<Key, Key, const SE3d&, SqrtInformation>(), py::arg("i"), py::arg("j"), py::arg("z"),
           py::arg("noise"))
      .def_property_readonly("measured", &BetweenSE3::measured);
  py::class_<PriorSE2, Factor, std::shared_ptr<PriorSE2>>(m, "PriorSE2")
      .def(py::init<Key, const SE2d&, SqrtInformation>(), py::arg("key"), py::arg("z"), py::arg("noise"));
  py::class_<PriorSE3, Factor, std::shared_ptr<PriorSE3>>(m, "PriorSE3")
      .def(py::init<Key, const SE3d&, SqrtInformation>(), py::arg("key"), py::arg("z"), py::arg("noise"));
  py::class_<PosePoint2, Factor, std::shared_ptr<PosePoint2>>(m, "PosePoint2", "A 2D point seen from an SE2 pose.")
      .def(py::init<Key, Key, const Eigen::Vector2d&, SqrtInformation>(), py::arg("pose"), py::arg("point"),
           py::arg("z"), py::arg("noise"));
  py::class_<PosePoint3, Factor, std::shared_ptr<PosePoint3>>(m, "PosePoint3", "A 3D point seen from an SE3 pose.")
      .def(py::init<Key, Key, const Eigen::Vector3d&, SqrtInformation>(), py::arg("pose"), py::arg("point"),
           py::arg("z"), py::arg("noise"));
  py::class_<RangeBearing2, Factor, std::shared_ptr<RangeBearing2>>(m, "RangeBearing2",
                                                                    "Range and bearing from an SE2 pose to a 2D point.")
      .def(py::init<Key, Key, double, double, SqrtInformation>(), py::arg("pose"), py::arg("point"), py::arg("range"),
           py::arg("bearing"), py::arg("noise"))
      .def_property_readonly("range", &RangeBearing2::range)
      .def_property_readonly("bearing", &RangeBearing2::bearing);
  py::class_<SwitchableFactor, Factor, std::shared_ptr<SwitchableFactor>>(
      m, "SwitchableFactor", "A factor scaled by a switch variable (type 'Switch', in [0, 1]) as its last key.")
      .def(py::init([](const Factor& inner, Key s) { return std::make_shared<SwitchableFactor>(inner.Clone(), s); }),
           py::arg("inner"), py::arg("switch_key"))
      .def_property_readonly("switch_key", &SwitchableFactor::switch_key)
      .def_property_readonly("inner", [](const SwitchableFactor& f) { return FactorPtr(f.inner().Clone()); });
  py::class_<SwitchPrior, Factor, std::shared_ptr<SwitchPrior>>(m, "SwitchPrior")
      .def(py::init<Key, double, SqrtInformation>(), py::arg("switch_key"), py::arg("prior"), py::arg("noise"));

  m.def(
      "make_factor",
      [](const std::string& type_name, const std::vector<Key>& keys, const std::vector<double>& measurement,
         const SqrtInformation& noise) {
        const Registry& r = DefaultRegistry();
        const FactorType* t = r.FindByName(type_name);
        if (t == nullptr) t = r.FindByTag(type_name);
        if (t == nullptr) {
          std::string names;
          for (const auto& [name, type] : r.types()) names += (names.empty() ? "" : ", ") + name;
          throw InvalidArgument("no factor type is named '" + type_name + "'; known types: " + names +
                                " (a plugin's types are known once load_plugin has loaded it)");
        }
        if (keys.size() != t->variable_types.size()) {
          throw InvalidArgument(t->name + " takes " + std::to_string(t->variable_types.size()) + " keys, got " +
                                std::to_string(keys.size()));
        }
        if (static_cast<int>(measurement.size()) != t->measurement_size) {
          throw InvalidArgument(t->name + " takes a measurement of " + std::to_string(t->measurement_size) +
                                " numbers (" + t->measurement_layout + "), got " + std::to_string(measurement.size()));
        }
        if (noise.dim() != t->dim) {
          throw InvalidArgument(t->name + " takes a noise model of dimension " + std::to_string(t->dim) + ", got " +
                                std::to_string(noise.dim()));
        }
        if (!t->make) throw InvalidArgument(t->name + " cannot be made from a measurement (its type has no maker)");
        return FactorPtr(t->make(keys, measurement.data(), noise));
      },
      py::arg("type_name"), py::arg("keys"), py::arg("measurement"), py::arg("noise"),
      "Any registered factor type (built-in or a plugin's) by name or g2o tag, from its measurement in the "
      "file layout.");
  m.def(
      "factor_types",
      [] {
        py::list out;
        for (const auto& [name, t] : DefaultRegistry().types()) {
          py::dict d;
          d["name"] = name;
          d["tag"] = t.tag;
          d["owner"] = t.owner;
          d["dim"] = t.dim;
          std::vector<std::string> vt;
          for (VarType v : t.variable_types) vt.emplace_back(ToString(v));
          d["variable_types"] = vt;
          d["measurement_size"] = t.measurement_size;
          d["measurement_layout"] = t.measurement_layout;
          out.append(d);
        }
        return out;
      },
      "The registered factor types (built-in and loaded plugins'), as dicts.");
  m.def(
      "variable_types",
      [] {
        std::vector<std::string> names;
        for (const auto& [name, t] : DefaultRegistry().variable_types()) names.push_back(name);
        return names;
      },
      "The registered variable type names.");
}

void BindFactorGraph(py::module_& m) {
  py::class_<FactorGraph>(m, "FactorGraph", "Factors by handle, and the variables held fixed.")
      .def(py::init<>())
      .def("copy", [](const FactorGraph& g) { return CopiedGraph(g); })
      .def("__copy__", [](const FactorGraph& g) { return CopiedGraph(g); })
      .def(
          "add",
          [](FactorGraph& g, const Factor& f) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kWrite);
            f.CheckShape();
            return g.Add(f.Clone());
          },
          py::arg("factor"), "Adds a copy of the factor; returns its handle.")
      .def(
          "add_between_se2_batch",
          [](FactorGraph& g, const py::object& i, const py::object& j, const DoubleArray& z, const DoubleArray& info) {
            return AddBatch(g, i, j, z, info, 3, 3, [](Key a, Key b, const double* p, const SqrtInformation& n) {
              return std::make_unique<BetweenSE2>(a, b, SE2d(p[0], p[1], p[2]), n);
            });
          },
          py::arg("i"), py::arg("j"), py::arg("z"), py::arg("information"),
          "N BetweenSE2 factors: i, j (N,) uint64; z (N, 3) = (x, y, theta); information (3, 3) for all or "
          "(N, 3, 3). All or nothing; returns the handles (N,).")
      .def(
          "add_between_se3_batch",
          [](FactorGraph& g, const py::object& i, const py::object& j, const DoubleArray& z, const DoubleArray& info) {
            return AddBatch(g, i, j, z, info, 7, 6, [](Key a, Key b, const double* p, const SqrtInformation& n) {
              return std::make_unique<BetweenSE3>(a, b, SE3d::FromParams(p), n);
            });
          },
          py::arg("i"), py::arg("j"), py::arg("z"), py::arg("information"),
          "N BetweenSE3 factors: z (N, 7) = (x, y, z, qx, qy, qz, qw); information (6, 6) or (N, 6, 6).")
      .def(
          "add_pose_point2_batch",
          [](FactorGraph& g, const py::object& i, const py::object& j, const DoubleArray& z, const DoubleArray& info) {
            return AddBatch(g, i, j, z, info, 2, 2, [](Key a, Key b, const double* p, const SqrtInformation& n) {
              return std::make_unique<PosePoint2>(a, b, Eigen::Vector2d(p[0], p[1]), n);
            });
          },
          py::arg("pose"), py::arg("point"), py::arg("z"), py::arg("information"),
          "N PosePoint2 factors: z (N, 2); information (2, 2) or (N, 2, 2).")
      .def(
          "remove",
          [](FactorGraph& g, FactorId id) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kWrite);
            if (!g.Remove(id)) {
              throw InvalidArgument("remove: the graph has no factor with handle " + std::to_string(id) +
                                    " (handles come from add; graph.handles() lists them)");
            }
          },
          py::arg("handle"), "Removes the factor with that handle; raises InvalidArgument where there is none.")
      .def("__len__", Reads(&FactorGraph::size, "FactorGraph"))
      .def("size", Reads(&FactorGraph::size, "FactorGraph"))
      .def(
          "__getitem__",
          [](const FactorGraph& g, long i) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
            const long n = static_cast<long>(g.size());
            if (i < 0) i += n;
            if (i < 0 || i >= n) throw py::index_error("factor index out of range");
            return FactorPtr(g.at(static_cast<std::size_t>(i)).Clone());
          },
          "A copy of the i-th factor.")
      .def("handle", Reads(&FactorGraph::id, "FactorGraph"), py::arg("index"))
      .def("handles",
           [](const FactorGraph& g) {
             InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
             std::vector<FactorId> ids(g.size());
             for (std::size_t i = 0; i < g.size(); ++i) ids[i] = g.id(i);
             return ids;
           })
      .def(
          "index_of",
          [](const FactorGraph& g, FactorId id) -> py::object {
            InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
            std::size_t i;
            if (!g.IndexOf(id, &i)) return py::none();
            return py::int_(i);
          },
          py::arg("handle"), "The position of the factor with that handle, or None.")
      .def(
          "set_loss",
          [](FactorGraph& g, FactorId id, const py::object& loss) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kWrite);
            std::size_t i;
            if (!g.IndexOf(id, &i)) throw InvalidArgument("the graph has no factor with handle " + std::to_string(id));
            g.at(i).set_loss(LossFrom(loss));
          },
          py::arg("handle"), py::arg("loss"), "Sets (or, with None, clears) the loss of the factor with that handle.")
      .def("fix", Writes(&FactorGraph::Fix, "FactorGraph"), py::arg("key"))
      .def("unfix", Writes(&FactorGraph::Unfix, "FactorGraph"), py::arg("key"))
      .def("is_fixed", Reads(&FactorGraph::IsFixed, "FactorGraph"), py::arg("key"))
      .def_property_readonly("fixed", Reads(&FactorGraph::fixed, "FactorGraph"))
      .def(
          "chi2",
          [](const FactorGraph& g, const Values& v) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return g.Chi2(v); });
          },
          py::arg("values"), "Sum of e^T Omega e over the factors (without losses).")
      .def(
          "cost",
          [](const FactorGraph& g, const Values& v) {
            InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
            InUse::Check(&v, "Values", InUse::Access::kRead);
            return Guarded([&] { return g.Cost(v); });
          },
          py::arg("values"), "The objective the solvers minimise (losses applied).")
      .def("has_loss", Reads(&FactorGraph::HasLoss, "FactorGraph"))
      .def("__repr__", [](const FactorGraph& g) {
        InUse::Check(&g, "FactorGraph", InUse::Access::kRead);
        return "FactorGraph(" + std::to_string(g.size()) + " factors)";
      });
}

}  // namespace

void BindGraph(py::module_& m) {
  BindNoiseAndLosses(m);
  BindValues(m);
  BindFactors(m);
  BindFactorGraph(m);
}
TETHER_PYTHON_PART(20, BindGraph);

}  // namespace python
}  // namespace tether
