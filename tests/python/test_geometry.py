"""Lie groups, keys and the shapes and dtypes of the arrays they exchange."""
import math

import numpy as np
import pytest

import tether


def test_se2_arrays_and_group_laws():
    a = tether.SE2(1.0, 2.0, 0.5)
    b = tether.SE2.from_params(np.array([-0.3, 0.7, 3.0]))
    assert a.params().shape == (3,) and a.params().dtype == np.float64
    assert a.translation().shape == (2,)
    assert a.matrix().shape == (3, 3)
    np.testing.assert_allclose((a * b).matrix(), a.matrix() @ b.matrix(), atol=1e-12)
    np.testing.assert_allclose((a * a.inverse()).params(), [0, 0, 0], atol=1e-12)
    p = np.array([0.4, -1.0])
    np.testing.assert_allclose(a * p, (a.matrix() @ np.append(p, 1.0))[:2], atol=1e-12)
    np.testing.assert_allclose(tether.SE2.exp(a.log()).params(), a.params(), atol=1e-12)
    d = a.local(b)
    np.testing.assert_allclose(a.retract(d).params(), b.params(), atol=1e-12)
    # theta is wrapped to (-pi, pi]
    assert tether.SE2(0, 0, 3 * math.pi).theta == pytest.approx(math.pi)


def test_se3_arrays_and_group_laws():
    r = tether.SO3.exp(np.array([0.1, -0.2, 0.3]))
    a = tether.SE3(r, np.array([1.0, 2.0, 3.0]))
    b = tether.SE3.from_params(np.array([0.5, 0.0, -1.0, 0.0, 0.0, math.sin(0.4), math.cos(0.4)]))
    assert a.params().shape == (7,)
    assert a.quaternion().shape == (4,)
    assert a.matrix().shape == (4, 4)
    assert a.adjoint().shape == (6, 6)
    np.testing.assert_allclose((a * b).matrix(), a.matrix() @ b.matrix(), atol=1e-12)
    np.testing.assert_allclose(tether.SE3.exp(a.log()).matrix(), a.matrix(), atol=1e-12)
    np.testing.assert_allclose(a.retract(a.local(b)).matrix(), b.matrix(), atol=1e-12)
    m = tether.SE3(a.matrix()[:3, :3], a.translation())
    np.testing.assert_allclose(m.matrix(), a.matrix(), atol=1e-12)
    np.testing.assert_allclose(tether.SO3(r.matrix()).log(), [0.1, -0.2, 0.3], atol=1e-12)


def test_bad_rotations_and_quaternions_are_refused():
    with pytest.raises(tether.InvalidArgument, match="not a rotation matrix"):
        tether.SO3(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(tether.InvalidArgument, match="non-zero norm"):
        tether.SE3.from_quaternion(np.zeros(4), np.zeros(3))
    with pytest.raises(TypeError):
        tether.SE2.from_params(np.zeros(4))


def test_symbols():
    k = tether.Symbol("x", 12)
    assert tether.key_to_string(k) == "x12"
    assert tether.symbol_letter(k) == "x" and tether.symbol_index(k) == 12
    assert tether.key_to_string(7) == "7"
