"""SO(3) reference kernels: identities, agreement with scipy, gyro integration, slerp."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from evstar_kernels.reference import so3

rng = np.random.default_rng(12)


def random_rotvecs(n, max_angle=math.pi * 0.999):
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    # angles spanning the polynomial branch (< 0.01 rad) and the sin/cos branch
    angle = np.concatenate([10 ** rng.uniform(-9, -2, n // 2), rng.uniform(0, max_angle, n - n // 2)])
    return axis * angle[:, None]


def same_rotation(qa, qb, atol=1e-12):
    dots = np.abs(np.sum(qa * qb, axis=-1))
    np.testing.assert_allclose(dots, 1.0, atol=atol)


def test_exp_matches_scipy_and_log_inverts_it():
    v = random_rotvecs(2000)
    q = so3.quat_exp(v)
    same_rotation(q, Rotation.from_rotvec(v).as_quat())
    np.testing.assert_allclose(so3.quat_log(q), v, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)


def test_polynomial_branch_is_continuous_at_the_threshold():
    a = math.sqrt(so3.SMALL_ANGLE2)
    v = np.array([[a * (1 - 1e-12), 0, 0], [a * (1 + 1e-12), 0, 0]])
    q = so3.quat_exp(v)
    np.testing.assert_allclose(q[0], q[1], atol=1e-15)
    np.testing.assert_allclose(q[1], [math.sin(a / 2), 0, 0, math.cos(a / 2)], atol=1e-17)


def test_matrix_maps_agree_with_rodrigues():
    v = random_rotvecs(500)
    R = so3.exp_so3(v)
    np.testing.assert_allclose(R, Rotation.from_rotvec(v).as_matrix(), atol=1e-13)
    np.testing.assert_allclose(so3.log_so3(R), v, atol=1e-9)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)


def test_quat_matrix_round_trip_covers_every_pivot():
    q = so3.quat_normalize(rng.normal(size=(1000, 4)))
    q = np.where(q[:, 3:] < 0, -q, q)
    back = so3.quat_from_matrix(so3.quat_to_matrix(q))
    np.testing.assert_allclose(back, q, atol=1e-13)
    # 180° rotations about each axis exercise the three non-trace pivots
    for axis in np.eye(3):
        same_rotation(so3.quat_from_matrix(so3.exp_so3(axis * math.pi)), np.r_[axis, 0.0])


def test_hat_vee_and_cross():
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    np.testing.assert_allclose(so3.hat(a) @ b[..., None], np.cross(a, b)[..., None], atol=1e-14)
    np.testing.assert_allclose(so3.vee(so3.hat(a)), a)


def test_product_rotate_and_conjugate_follow_matrices():
    qa, qb = so3.quat_exp(random_rotvecs(300)), so3.quat_exp(random_rotvecs(300))
    Ra, Rb = so3.quat_to_matrix(qa), so3.quat_to_matrix(qb)
    np.testing.assert_allclose(so3.quat_to_matrix(so3.quat_mul(qa, qb)), Ra @ Rb, atol=1e-13)
    v = rng.normal(size=(300, 3))
    np.testing.assert_allclose(so3.quat_rotate(qa, v), (Ra @ v[..., None])[..., 0], atol=1e-13)
    np.testing.assert_allclose(so3.quat_to_matrix(so3.quat_conj(qa)), np.swapaxes(Ra, 1, 2), atol=1e-13)


def test_constant_rate_integration_gives_the_expected_rotation():
    omega = np.array([0.2, -0.35, 0.1])  # rad/s, ~25 °/s
    dt = np.full(5000, 1e-3)
    q0 = so3.quat_exp([0.3, 0.2, -1.0])
    q = so3.integrate_rates(q0, np.tile(omega, (len(dt), 1)), dt)
    t = np.r_[0, np.cumsum(dt)]
    # dR_cw/dt = −[ω]× R_cw  =>  R_cw(t) = Exp(−ω t) R_cw(0)
    expect = so3.quat_mul(so3.quat_exp(-np.outer(t, omega)), q0)
    same_rotation(q, expect, atol=1e-13)
    # the derivative convention, checked directly on the first step
    R0, R1 = so3.quat_to_matrix(q[0]), so3.quat_to_matrix(q[1])
    np.testing.assert_allclose((R1 - R0) / 1e-3, -so3.hat(omega) @ R0, atol=1e-3)


def test_prefix_scan_equals_sequential_product():
    omega, dt = rng.normal(size=(777, 3)), rng.uniform(1e-4, 2e-3, 777)
    q0 = so3.quat_exp([0.1, 0.0, 0.2])
    seq = [q0]
    for w, h in zip(omega, dt):
        seq.append(so3.quat_mul(so3.quat_exp(-w * h), seq[-1]))
    np.testing.assert_allclose(so3.integrate_rates(q0, omega, dt), so3.quat_normalize(np.array(seq)),
                               atol=1e-13)


def test_slerp_endpoints_midpoint_and_constant_speed():
    q0, q1 = so3.quat_exp(random_rotvecs(200, max_angle=3.0)), so3.quat_exp(random_rotvecs(200, 3.0))
    same_rotation(so3.slerp(q0, q1, np.zeros(200)), q0)
    same_rotation(so3.slerp(q0, q1, np.ones(200)), q1)
    d = so3.quat_log(so3.quat_mul(so3.quat_conj(q0), q1))  # the shortest relative rotation
    for s in (0.25, 0.5, 0.9):
        qs = so3.slerp(q0, q1, np.full(200, s))
        np.testing.assert_allclose(so3.quat_log(so3.quat_mul(so3.quat_conj(q0), qs)), s * d, atol=1e-10)
    # shortest path: −q1 is the same rotation and gives the same interpolant
    same_rotation(so3.slerp(q0, -q1, np.full(200, 0.3)), so3.slerp(q0, q1, np.full(200, 0.3)))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3).filter(lambda v: np.linalg.norm(v) < 3.1))
def test_log_of_exp_is_identity(v):
    np.testing.assert_allclose(so3.quat_log(so3.quat_exp(np.array(v))), v, atol=1e-12)


@pytest.mark.parametrize("angle", [0.0, 1e-14, 1e-6])
def test_log_near_identity(angle):
    v = np.array([angle, -angle, 0.5 * angle])
    np.testing.assert_allclose(so3.quat_log(so3.quat_exp(v)), v, atol=1e-20)
