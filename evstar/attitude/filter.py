"""Multiplicative EKF on SO(3): the inertial attitude from identified star directions.

The numpy code here is the specification of the filter steps (tests hold the estimator to
it). State: the attitude R (camera -> ICRS; a camera-frame vector v becomes R v) and a
3-vector s, which is

* the gyro bias b (camera frame, rad/s; the gyro reads ω + b + noise) when an IMU drives
  the prediction (``mode="imu"``), or
* the body rate ω and angular acceleration α (camera frame) under a constant-acceleration
  model with white angular jerk (``mode="rate"``), when there is no IMU.

The covariance P is that of the error [δθ, δs], with δθ in the body frame:
R_true = R · Exp(δθ). With dR_cw/dt = −[ω]× R_cw (docs/design.md), R = R_cwᵀ obeys
dR/dt = R [ω]×, so a step of rate ω over dt is R ← R · Exp(ω dt).

A measurement is a star's centroid as pinhole-normalised coordinates z = (x/z, y/z) of its
camera ray, predicted from the catalogue direction d as π(Rᵀ d); its Jacobian in δθ is
∂π/∂v · [v]× (since Rᵀ_true d = Exp(−δθ) v ≈ v + [v]× δθ).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

MODES = ("imu", "rate")


def hat(v):
    """[v]×, the cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def exp_so3_many(phi):
    """Rodrigues for stacked rotation vectors (m, 3) -> (m, 3, 3)."""
    phi = np.asarray(phi, float).reshape(-1, 3)
    a2 = np.einsum("mi,mi->m", phi, phi)
    a = np.sqrt(a2)
    small = a < 1e-8
    safe = np.where(small, 1.0, a)
    c1 = np.where(small, 1.0 - a2 / 6, np.sin(safe) / safe)
    c2 = np.where(small, 0.5 - a2 / 24, (1 - np.cos(safe)) / (safe * safe))
    K = np.zeros((len(phi), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    K -= K.transpose(0, 2, 1)
    return np.eye(3) + c1[:, None, None] * K + c2[:, None, None] * (K @ K)


def exp_so3(phi):
    """Rodrigues: the rotation matrix of rotation vector `phi` (3,)."""
    a = math.sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2])
    K = hat(phi)
    if a < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + (math.sin(a) / a) * K + ((1 - math.cos(a)) / (a * a)) * K @ K


class Mekf:
    """One filter: R (3, 3) camera -> ICRS, state s and covariance P of [δθ, δs].

    mode "imu": s = gyro bias b (3,), P (6, 6); gyro_noise (rad/s/√Hz) and bias_walk
    (rad/s²/√Hz) model the gyro. mode "rate": s = [ω, α] (6,), body rate and angular
    acceleration, P (9, 9); jerk_noise (rad/s³/√Hz, white angular jerk) models the motion —
    a constant rate would lag an acceleration by α·dt²/2 over each prediction (0.3 px in
    10 ms on the 10°/1 Hz sinusoid at f = 870 px).
    """

    def __init__(self, R, s, P, mode, *, gyro_noise=0.0, bias_walk=0.0, jerk_noise=0.0):
        if mode not in MODES:
            raise ParameterError(f"mode must be one of {MODES}, got {mode!r}")
        self.R = np.array(R, float)
        self.s = np.array(s, float)
        self.P = np.array(P, float)
        n = 6 if mode == "rate" else 3
        if self.s.shape != (n,) or self.P.shape != (n + 3, n + 3):
            raise ParameterError(f"mode {mode!r} needs s ({n},) and P ({n + 3}, {n + 3})")
        self.mode = mode
        self.gyro_noise, self.bias_walk, self.jerk_noise = gyro_noise, bias_walk, jerk_noise

    def copy(self):
        return Mekf(self.R, self.s, self.P, self.mode, gyro_noise=self.gyro_noise,
                    bias_walk=self.bias_walk, jerk_noise=self.jerk_noise)

    def rate(self, gyro=None):
        """Body rate estimate (camera frame, rad/s): the state's in rate mode, the gyro
        reading less the bias in imu mode."""
        return self.s[:3].copy() if self.mode == "rate" else np.asarray(gyro, float) - self.s

    # -- prediction -----------------------------------------------------------------------
    def predict(self, dt, gyro=None):
        """Advance by dt seconds; in imu mode `gyro` is the mean gyro reading over the step
        (camera frame). Returns the error-state transition F of the step (a smoother's)."""
        n, I = len(self.P), np.eye(3)
        if dt <= 0:
            return np.eye(n)
        F, Q = np.eye(n), np.zeros((n, n))
        if self.mode == "rate":
            w, a = self.s[:3], self.s[3:]
            step = exp_so3(w * dt + a * dt * dt / 2)
            self.s = np.r_[w + a * dt, a]
            F[:3, 3:6], F[:3, 6:], F[3:6, 6:] = I * dt, I * dt * dt / 2, I * dt
            q = self.jerk_noise ** 2 * np.array([[dt ** 5 / 20, dt ** 4 / 8, dt ** 3 / 6],
                                                  [dt ** 4 / 8, dt ** 3 / 3, dt ** 2 / 2],
                                                  [dt ** 3 / 6, dt ** 2 / 2, dt]])
            Q = np.kron(q, I)
        else:
            step = exp_so3(self.rate(gyro) * dt)
            F[:3, 3:] = -I * dt                 # the bias is subtracted from the gyro
            Q[:3, :3] = I * self.gyro_noise ** 2 * dt
            Q[3:, 3:] = I * self.bias_walk ** 2 * dt
        self.R = self.R @ step
        F[:3, :3] = step.T                      # δθ' = Exp(−ω dt) δθ + ...
        P = F @ self.P @ F.T + Q
        self.P = 0.5 * (P + P.T)
        return F

    # -- update ---------------------------------------------------------------------------
    def residuals(self, z, dirs, dt=None, rates=None):
        """Innovation r (m, 2) and Jacobian H (m, 2, n) of normalised coordinates `z` (m, 2)
        observed for catalogue directions `dirs` (m, 3, ICRS) at dt (m,) seconds from the
        filter's time (default 0). The body turns by φ in between — ω dt + α dt²/2 in rate
        mode, `rates` (m, 3: mean gyro less bias) times dt in imu mode — so the star's ray
        is v = Exp(φ)ᵀ Rᵀ d, with Jacobian [v]× Exp(φ)ᵀ in δθ, dt·[v]× in δω,
        dt²/2·[v]× in δα (−dt·[v]× in the bias, ω = gyro − b)."""
        m = len(z)
        u = np.asarray(dirs, float) @ self.R            # rows: Rᵀ d, camera frame
        dt = np.zeros(m) if dt is None else np.asarray(dt, float)
        if self.mode == "rate":
            phi = dt[:, None] * self.s[:3] + (dt * dt / 2)[:, None] * self.s[3:]
        else:
            phi = dt[:, None] * (np.zeros((m, 3)) if rates is None else np.asarray(rates, float))
        E = exp_so3_many(phi)                           # R(t_i) = R · E_i
        v = np.einsum("mji,mj->mi", E, u)               # E_iᵀ u_i
        inv = 1.0 / v[:, 2]
        pred = v[:, :2] * inv[:, None]
        D = np.zeros((m, 2, 3))                         # ∂π/∂v
        D[:, 0, 0] = D[:, 1, 1] = inv
        D[:, :, 2] = -pred * inv[:, None]
        Vx = np.zeros((m, 3, 3))                        # [v]× per star
        Vx[:, 0, 1], Vx[:, 0, 2], Vx[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
        Vx -= Vx.transpose(0, 2, 1)
        DV = D @ Vx
        H = np.zeros((m, 2, len(self.P)))
        H[:, :, :3] = DV @ E.transpose(0, 2, 1)
        if self.mode == "rate":
            H[:, :, 3:6] = DV * dt[:, None, None]
            H[:, :, 6:] = DV * (dt * dt / 2)[:, None, None]
        else:
            H[:, :, 3:] = -DV * dt[:, None, None]
        return np.asarray(z, float) - pred, H

    def update(self, z, dirs, sigma, dt=None, rates=None, gate=None):
        """Joint update with stars seen around the current time: normalised coordinates z
        (m, 2) of catalogue directions dirs (m, 3), per-axis noise sigma (m, 2), times and
        rates as in :meth:`residuals`. With `gate` (sigmas), a star is left out whose
        innovation is unlikely before the update (χ², 2 dof, > gate²) or whose residual
        after a trial update with the others still exceeds gate measurement sigmas (an
        outlier a loose prior would let through). Returns the mask of the stars used."""
        dt = np.zeros(len(z)) if dt is None else np.asarray(dt, float)
        r, H = self.residuals(z, dirs, dt, rates)
        var = np.asarray(sigma, float) ** 2 + self._motion_var(dt)[:, None]
        used = np.all(np.isfinite(r), axis=1)
        if gate is not None:
            S = H @ self.P @ H.transpose(0, 2, 1)
            S[:, 0, 0] += var[:, 0]
            S[:, 1, 1] += var[:, 1]
            used &= np.einsum("mi,mij,mj->m", r, np.linalg.inv(S), r) <= gate * gate
            if used.sum() > 2:
                trial = self.copy()
                trial._apply(*_stacked(r, H, var, used))
                r_post, _ = trial.residuals(z, dirs, dt, rates)
                used &= np.sum(r_post ** 2 / var, axis=1) <= gate * gate
        if used.any():
            self._apply(*_stacked(r, H, var, used))
        return used

    def _motion_var(self, dt):
        """Variance (per axis, normalised units ≈ rad near the centre) the process noise
        adds to a star seen dt from the filter's time: its motion over dt is modelled, not
        known (white jerk q·|dt|⁵/20, gyro noise σ²·|dt|)."""
        a = np.abs(dt)
        if self.mode == "rate":
            return self.jerk_noise ** 2 * a ** 5 / 20
        return self.gyro_noise ** 2 * a

    def _apply(self, r, H, var):
        """Joint Kalman update of stacked rows, then the reset of δθ into R. The noise is
        diagonal, so the information form — P⁺ = (P⁻¹ + Hᵀ V⁻¹ H)⁻¹, dx = P⁺ Hᵀ V⁻¹ r — needs
        only n x n inverses (n = 6 or 9) instead of a (2m x 2m) one for m stars."""
        HtW = H.T / var
        P = np.linalg.inv(np.linalg.inv(self.P) + HtW @ H)
        dx = P @ (HtW @ r)
        self.P = 0.5 * (P + P.T)
        self.R = self.R @ exp_so3(dx[:3])
        self.s = self.s + dx[3:]

    @property
    def attitude_sigma(self):
        """1-σ attitude error (rad): the root of the trace of its covariance (a bound on
        the largest axis's, cheaper than eigenvalues at every output)."""
        return math.sqrt(max(self.P[0, 0] + self.P[1, 1] + self.P[2, 2], 0.0))


def log_so3(R):
    """The rotation vector of rotation matrix R (3, 3), angle below π (inverse of exp_so3;
    a smoother's corrections are small)."""
    w = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    a = math.acos(min(1.0, max(-1.0, (R[0, 0] + R[1, 1] + R[2, 2] - 1) / 2)))
    return w if a < 1e-6 else w * (a / math.sin(a))


def rts_gains(P, P_next_pred, F_next):
    """Rauch–Tung–Striebel gain C = P Fᵀ (P⁻)⁻¹ of one node: its filtered covariance P, and
    the transition F to the next node with that node's predicted covariance P⁻."""
    return np.linalg.solve(P_next_pred, F_next @ P).T


def smooth(nodes):
    """RTS pass over one filter's nodes, in time order, of the error state [δθ, δs]. Each
    node is a dict with the filter's R, s, P after its update (R, s, P), before it (R_pred,
    s_pred, P_pred) and F, the transition from the previous node. Returns (R, s, P) smoothed
    per node; the last node's equal its filtered ones. The error of a node is
    e = [Log(Rᵀ R_s), s_s − s] (R_true = R·Exp(δθ)), carried back as e_k = C_k e_{k+1}."""
    last = nodes[-1]
    out = [None] * len(nodes)
    out[-1] = (last["R"], last["s"], last["P"])
    for k in range(len(nodes) - 2, -1, -1):
        a, b = nodes[k], nodes[k + 1]
        R_n, s_n, P_n = out[k + 1]
        C = rts_gains(a["P"], b["P_pred"], b["F"])
        e = C @ np.r_[log_so3(b["R_pred"].T @ R_n), s_n - b["s_pred"]]
        P = a["P"] + C @ (P_n - b["P_pred"]) @ C.T
        out[k] = (a["R"] @ exp_so3(e[:3]), a["s"] + e[3:], 0.5 * (P + P.T))
    return out


def _stacked(r, H, var, used):
    """The used stars' rows stacked: residuals (2k,), Jacobian (2k, n), variances (2k,)."""
    return r[used].reshape(-1), H[used].reshape(-1, H.shape[-1]), var[used].reshape(-1)
