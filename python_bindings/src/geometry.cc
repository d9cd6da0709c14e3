// Lie groups (SO2, SO3, SE2, SE3) and keys. Vectors and matrices are float64 NumPy arrays:
// a 2D point (2,), a 3D point (3,), an SE2 tangent (3,) = (dx, dy, dtheta), an SE3 tangent
// (6,) = (translation, rotation), rotation matrices (2, 2) / (3, 3), homogeneous matrices
// (3, 3) / (4, 4), quaternions (4,) in the file order (qx, qy, qz, qw).
#include <cmath>
#include <sstream>

#include "common.h"
#include "tether/core/key.h"
#include "tether/core/se2.h"
#include "tether/core/se3.h"

namespace tether {
namespace python {

namespace {

template <class T>
std::string Repr(const T& v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

// A rotation matrix checked to be one (orthonormal, determinant +1, within 1e-6).
Eigen::Quaterniond QuaternionFromMatrix(const Eigen::Matrix3d& r) {
  const double off = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(off < 1e-6) || !(r.determinant() > 0)) {
    throw InvalidArgument("not a rotation matrix: R^T R differs from the identity by " + std::to_string(off) +
                          " and det(R) = " + std::to_string(r.determinant()) +
                          " (orthonormal with determinant +1 is needed, within 1e-6)");
  }
  return Eigen::Quaterniond(r).normalized();
}

Eigen::Quaterniond QuaternionFromXyzw(const Eigen::Vector4d& q) {
  const double n = q.norm();
  if (!(n > 1e-12) || !std::isfinite(n)) {
    throw InvalidArgument("a quaternion (qx, qy, qz, qw) needs a finite, non-zero norm; got norm " + std::to_string(n));
  }
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized();
}

Eigen::Vector4d Xyzw(const Eigen::Quaterniond& q) { return Eigen::Vector4d(q.x(), q.y(), q.z(), q.w()); }

}  // namespace

void BindGeometry(py::module_& m) {
  m.def(
      "Symbol",
      [](char letter, std::uint64_t index) {
        if (letter < '!' || letter > '~') {
          throw InvalidArgument(
              "Symbol: the letter must be a printable ASCII character (not a space or control "
              "character), got code " +
              std::to_string(static_cast<int>(static_cast<unsigned char>(letter))));
        }
        if (index >= (std::uint64_t(1) << 56)) {
          throw InvalidArgument("Symbol: the index must be below 2**56 (72057594037927936), got " +
                                std::to_string(index) + "; a larger one would change the letter");
        }
        return Symbol(letter, index);
      },
      py::arg("letter"), py::arg("index"),
      "The key of a symbol: Symbol('x', 12) packs the letter into the top byte; key_to_string gives 'x12'.");
  m.def("symbol_letter", &SymbolLetter, py::arg("key"), "The letter of a symbol key ('\\0' for a plain number).");
  m.def("symbol_index", &SymbolIndex, py::arg("key"), "The index of a symbol key.");
  m.def("key_to_string", &KeyToString, py::arg("key"), "'x12' for symbol keys, the plain number otherwise.");
  m.def("wrap_angle", &WrapAngle<double>, py::arg("angle"), "The angle wrapped to (-pi, pi].");

  py::class_<SO2d>(m, "SO2", "A 2D rotation by an angle in (-pi, pi].")
      .def(py::init<>())
      .def(py::init<double>(), py::arg("theta"))
      .def_static("exp", &SO2d::Exp, py::arg("theta"))
      .def("log", &SO2d::Log)
      .def_property_readonly("angle", &SO2d::angle)
      .def("inverse", &SO2d::Inverse)
      .def("matrix", &SO2d::matrix, "The (2, 2) rotation matrix.")
      .def("__mul__", [](const SO2d& a, const SO2d& b) { return a * b; })
      .def("__mul__", [](const SO2d& a, const Eigen::Vector2d& p) { return Eigen::Vector2d(a * p); })
      .def("__repr__", [](const SO2d& r) { return "SO2(" + Repr(r.angle()) + ")"; });

  py::class_<SO3d>(m, "SO3", "A 3D rotation (unit quaternion).")
      .def(py::init<>())
      .def(py::init([](const Eigen::Matrix3d& r) { return SO3d(QuaternionFromMatrix(r)); }), py::arg("matrix"),
           "From a (3, 3) rotation matrix (checked).")
      .def_static(
          "from_quaternion", [](const Eigen::Vector4d& q) { return SO3d(QuaternionFromXyzw(q)); }, py::arg("q"),
          "From a quaternion (4,) = (qx, qy, qz, qw); normalised.")
      .def_static("exp", &SO3d::Exp, py::arg("w"), "From a rotation vector (3,).")
      .def("log", &SO3d::Log, "The rotation vector (3,).")
      .def(
          "quaternion", [](const SO3d& r) { return Xyzw(r.quaternion()); }, "(4,) = (qx, qy, qz, qw).")
      .def("matrix", &SO3d::matrix, "The (3, 3) rotation matrix.")
      .def("inverse", &SO3d::Inverse)
      .def("adjoint", &SO3d::Adjoint)
      .def("__mul__", [](const SO3d& a, const SO3d& b) { return a * b; })
      .def("__mul__", [](const SO3d& a, const Eigen::Vector3d& p) { return Eigen::Vector3d(a * p); })
      .def("__repr__", [](const SO3d& r) {
        const Eigen::Vector4d q = Xyzw(r.quaternion());
        return "SO3(q: " + Repr(q[0]) + ", " + Repr(q[1]) + ", " + Repr(q[2]) + ", " + Repr(q[3]) + ")";
      });

  py::class_<SE2d>(m, "SE2", "A 2D pose (x, y, theta), theta wrapped to (-pi, pi].")
      .def(py::init<>())
      .def(py::init<double, double, double>(), py::arg("x"), py::arg("y"), py::arg("theta"))
      .def(py::init([](const SO2d& r, const Eigen::Vector2d& t) { return SE2d(r, t); }), py::arg("rotation"),
           py::arg("translation"))
      .def_static(
          "from_params", [](const Eigen::Vector3d& p) { return SE2d(p[0], p[1], p[2]); }, py::arg("params"),
          "From (3,) = (x, y, theta).")
      .def(
          "params", [](const SE2d& p) { return Eigen::Vector3d(p.x(), p.y(), p.theta()); }, "(3,) = (x, y, theta).")
      .def_property_readonly("x", &SE2d::x)
      .def_property_readonly("y", &SE2d::y)
      .def_property_readonly("theta", &SE2d::theta)
      .def(
          "translation", [](const SE2d& p) { return Eigen::Vector2d(p.translation()); }, "(2,)")
      .def("rotation", &SE2d::rotation)
      .def("inverse", &SE2d::Inverse)
      .def_static("exp", &SE2d::Exp, py::arg("v"), "From a tangent vector (3,).")
      .def("log", &SE2d::Log, "The tangent vector (3,).")
      .def("adjoint", &SE2d::Adjoint, "(3, 3)")
      .def("retract", &SE2d::Retract, py::arg("delta"), "Box-plus: translation += R delta[:2], theta += delta[2].")
      .def("local", &SE2d::Local, py::arg("other"), "Box-minus: the delta with self.retract(delta) == other.")
      .def("matrix", &SE2d::matrix, "The (3, 3) homogeneous matrix.")
      .def("__mul__", [](const SE2d& a, const SE2d& b) { return a * b; })
      .def("__mul__", [](const SE2d& a, const Eigen::Vector2d& p) { return Eigen::Vector2d(a * p); })
      .def("__repr__", [](const SE2d& p) { return Repr(p); });

  py::class_<SE3d>(m, "SE3", "A 3D pose: a rotation (unit quaternion) and a translation.")
      .def(py::init<>())
      .def(py::init([](const SO3d& r, const Eigen::Vector3d& t) { return SE3d(r, t); }), py::arg("rotation"),
           py::arg("translation"))
      .def(
          py::init([](const Eigen::Matrix3d& r, const Eigen::Vector3d& t) { return SE3d(QuaternionFromMatrix(r), t); }),
          py::arg("rotation"), py::arg("translation"),
          "From a (3, 3) rotation matrix (checked) and a (3,) translation.")
      .def_static(
          "from_quaternion",
          [](const Eigen::Vector4d& q, const Eigen::Vector3d& t) { return SE3d(QuaternionFromXyzw(q), t); },
          py::arg("q"), py::arg("translation"), "From (qx, qy, qz, qw) and a (3,) translation.")
      .def_static(
          "from_params",
          [](const Eigen::Matrix<double, 7, 1>& p) {
            return SE3d(QuaternionFromXyzw(p.tail<4>()), Eigen::Vector3d(p.head<3>()));
          },
          py::arg("params"), "From (7,) = (x, y, z, qx, qy, qz, qw); the quaternion is normalised.")
      .def(
          "params",
          [](const SE3d& p) {
            Eigen::Matrix<double, 7, 1> v;
            p.ToParams(v.data());
            return v;
          },
          "(7,) = (x, y, z, qx, qy, qz, qw).")
      .def(
          "translation", [](const SE3d& p) { return Eigen::Vector3d(p.translation()); }, "(3,)")
      .def("rotation", &SE3d::rotation)
      .def(
          "quaternion", [](const SE3d& p) { return Xyzw(p.quaternion()); }, "(4,) = (qx, qy, qz, qw).")
      .def("inverse", &SE3d::Inverse)
      .def_static("exp", &SE3d::Exp, py::arg("v"), "From a tangent vector (6,) = (translation part, rotation vector).")
      .def("log", &SE3d::Log, "The tangent vector (6,).")
      .def("adjoint", &SE3d::Adjoint, "(6, 6)")
      .def("retract", &SE3d::Retract, py::arg("delta"), "Box-plus: t += R delta[:3], R = R Exp(delta[3:]).")
      .def("local", &SE3d::Local, py::arg("other"), "Box-minus: the delta with self.retract(delta) == other.")
      .def("matrix", &SE3d::matrix, "The (4, 4) homogeneous matrix.")
      .def("__mul__", [](const SE3d& a, const SE3d& b) { return a * b; })
      .def("__mul__", [](const SE3d& a, const Eigen::Vector3d& p) { return Eigen::Vector3d(a * p); })
      .def("__repr__", [](const SE3d& p) { return Repr(p); });
}
TETHER_PYTHON_PART(10, BindGeometry);

}  // namespace python
}  // namespace tether
