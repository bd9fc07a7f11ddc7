# SPDX-License-Identifier: Apache-2.0
"""Training of the ECO filter: the normal equations and their conjugate-gradient solution.

Filter only (every later update; C-COT eq. 12 with ECO eq. 9's sample-space weights): minimise
    E(f) = sum_l pi_l || sum_d f^d X^d_l - y^ ||^2 + sum_d || w^ * f^d ||^2
over the half spectra f^d of the D compressed channels of every block; the normal equations are
    (A^H Gamma A + W^H W) f^ = A^H Gamma y^,
A the per-frequency sum over channels (blocks of different size summed in the centre of the largest grid),
Gamma = diag(pi). They are solved by preconditioned conjugate gradient (Polak-Ribiere), warm-started from the
previous filter and previous search direction, the latter forgotten by (1 - gamma)^`forgetting_rate` (ECO
Sec. 3.3 "N_CG iterations every N_S frames", reference `CG_forgetting_rate`). The preconditioner is diagonal:
(1 - b)(a E + (1 - a) mean_d E) + b ||w^||^2, E the running sample energy |x^|^2 (reference code).

Filter and projection on the first frame (ECO eq. 4-7): E(f, P) = || z^T P f - y ||^2 + sum_c ||w * f^c||^2
+ lambda ||P||_F^2 is minimised by Gauss-Newton: at (f_i, P_i) the residual is linearised (ECO eq. 5)
    z^T P_i f_{i+1} + (f_i (x) z)^T vec(dP) - y,
and each linear least-squares problem in (f_{i+1}, dP) (ECO eq. 6) is solved by a few CG iterations (ECO eq.
7;
Fletcher-Reeves, restarted every Gauss-Newton step, reference code). dP is real; its normal-equation part sums
over the whole spectrum, 2 Re(half) - Re(column kx = 0).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.eco.features import compiled
from swir_tracker_ros.core.eco.fourier import half_inner, symmetrise
from swir_tracker_ros.core.eco.regularisation import RegOperator
from swir_tracker_ros.core.kernels import corr_jit

Vec = list[np.ndarray]


@dataclass
class CGState:
    """The last search direction and rho of a CG run, for the warm start of the next (reference
    `CG_state`)."""

    p: Vec
    rho: float
    r_prev: Vec | None


def inner(a: Vec, b: Vec) -> float:
    """Full-spectrum real inner product of two lists of half spectra (`fourier.half_inner`)."""
    return sum(half_inner(x, y) for x, y in zip(a, b))


def _axpy(alpha: float, x: Vec, y: Vec) -> Vec:
    return [yi + np.float32(alpha) * xi for xi, yi in zip(x, y)]


def pcg(
    apply_a: Callable[[Vec], Vec],
    b: Vec,
    x0: Vec,
    precond: Callable[[Vec], Vec],
    ip: Callable[[Vec, Vec], float],
    maxit: int,
    state: CGState | None = None,
    forget: float = 1.0,
    fletcher_reeves: bool = False,
) -> tuple[Vec, CGState | None, list[float]]:
    """Preconditioned conjugate gradient on A x = b from x0 (reference `pcg_ccot`).

    With a previous `state` and forget > 0 the first direction continues the last one, its rho divided by
    `forget` (which shrinks beta: the old direction is partly forgotten). Returns (x, state, residual norms
    ||r|| before each iteration and after the last)."""
    x = x0
    r = [bi - ai for bi, ai in zip(b, apply_a(x))]
    p: Vec | None = None
    rho = 1.0
    r_prev: Vec | None = None
    if state is not None and forget > 0.0:
        p, rho, r_prev = state.p, state.rho / forget, state.r_prev
    norms = [ip(r, r) ** 0.5]
    for _ in range(maxit):
        z = precond(r)
        rho1, rho = rho, ip(r, z)
        if rho == 0.0 or not np.isfinite(rho):
            break
        if p is None:
            p = z
        else:
            fr = fletcher_reeves or r_prev is None
            beta = rho / rho1 if fr or r_prev is None else (rho - ip(r_prev, z)) / rho1
            if not np.isfinite(beta):
                break
            p = _axpy(max(beta, 0.0), p, z)
        q = apply_a(p)
        pq = ip(p, q)
        if pq <= 0.0 or not np.isfinite(pq):
            break
        alpha = rho / pq
        r_prev = r if not fletcher_reeves else None
        x = _axpy(alpha, p, x)
        r = _axpy(-alpha, q, r)
        norms.append(ip(r, r) ** 0.5)
    out = CGState(p, rho, r_prev) if p is not None else None
    return x, out, norms


class Geometry:
    """Where each block's half spectrum sits in the output grid (the largest block's, centred rows)."""

    def __init__(self, shapes: list[tuple[int, int]]) -> None:
        self.ny = max(s[0] for s in shapes)
        self.nx = max(s[1] for s in shapes)
        self.rows = [slice((self.ny - s[0]) // 2, (self.ny + s[0]) // 2) for s in shapes]
        self.cols = [s[1] for s in shapes]

    def crop(self, full: np.ndarray, b: int) -> np.ndarray:
        return full[..., self.rows[b], : self.cols[b]]


def scores(f: Vec, xs: Vec, geo: Geometry) -> np.ndarray:
    """sum_b embed(sum_d f_b^d X_b^d) for a batch of samples xs_b (L, D, rows, cols): (L, ny, nx)."""
    n = xs[0].shape[0]
    out = np.zeros((n, geo.ny, geo.nx), dtype=np.complex64)
    cj = corr_jit()
    for b, (fb, xb) in enumerate(zip(f, xs)):
        if cj is not None and xb.flags.c_contiguous:  # sum_d x conj(conj f): the KCF channel-sum loop
            d, ny, nx = fb.shape
            s = np.empty((n, ny * nx), dtype=np.complex64)
            cj.channel_sum_kernel(xb.reshape(n, d, ny * nx), np.conj(fb).reshape(d, ny * nx), s)
            out[:, geo.rows[b], : geo.cols[b]] += s.reshape(n, ny, nx)
        else:
            out[:, geo.rows[b], : geo.cols[b]] += np.einsum("ldyx,dyx->lyx", xb, fb)
    return out


def adjoint(s: np.ndarray, xs: Vec, geo: Geometry) -> Vec:
    """A^H: per block sum_l conj(X_l^d) s_l on the block's frequencies."""
    jit = compiled()
    out = []
    for b, xb in enumerate(xs):
        sb = geo.crop(s, b)
        if jit is not None and xb.flags.c_contiguous:
            n, d, ny, nx = xb.shape
            o = np.empty((d, ny * nx), dtype=np.complex64)
            jit.adjoint_kernel(xb.reshape(n, d, ny * nx), np.ascontiguousarray(sb).reshape(n, ny * nx), o)
            out.append(o.reshape(d, ny, nx))
        else:
            out.append(np.conj(np.einsum("ldyx,lyx->dyx", xb, np.conj(sb))))
    return out


def preconditioner(energy: Vec, regs: list[RegOperator], data_w: float, reg_w: float) -> Vec:
    """Diagonal M = (1 - reg_w)(data_w E + (1 - data_w) mean_d E) + reg_w ||w^||^2 per block (reference)."""
    return [
        (
            (1.0 - reg_w) * (data_w * e + (1.0 - data_w) * e.mean(axis=0, keepdims=True)) + reg_w * r.energy
        ).astype(np.float32)
        for e, r in zip(energy, regs)
    ]


def train_filter(
    f: Vec,
    xs: Vec,
    weights: np.ndarray,
    yf: Vec,
    regs: list[RegOperator],
    geo: Geometry,
    m_diag: Vec,
    maxit: int,
    state: CGState | None,
    forget: float,
) -> tuple[Vec, CGState | None, list[float]]:
    """`maxit` Polak-Ribiere CG iterations on the filter normal equations from f (C-COT eq. 12, ECO eq. 9)."""
    w = weights.astype(np.float32)
    # right-hand side A^H Gamma y^: conj(sum_l pi_l X_l) y^
    rhs = [np.conj(np.einsum("l,ldyx->dyx", w, xb)) * yb for xb, yb in zip(xs, yf)]

    def apply_a(v: Vec) -> Vec:
        s = scores(v, xs, geo) * w[:, None, None]
        return [a + r.apply(vb) for a, r, vb in zip(adjoint(s, xs, geo), regs, v)]

    def precond(v: Vec) -> Vec:
        return [vb / mb for vb, mb in zip(v, m_diag)]

    return pcg(apply_a, rhs, f, precond, inner, maxit, state, forget)


class _JointSystem:
    """The Gauss-Newton step's normal equations in (f, dP) at the linearisation point (f0, P) (ECO eq. 6)."""

    def __init__(
        self, x: Vec, p: list[np.ndarray], f0: Vec, regs: list[RegOperator], geo: Geometry, proj_reg: float
    ) -> None:
        self.x, self.f0, self.regs, self.geo, self.proj_reg = x, f0, regs, geo, proj_reg
        self.z = [np.einsum("cd,cyx->dyx", pb, xb) for pb, xb in zip(p, x)]  # P_i^T x
        self.nb = len(x)

    def apply(self, v: Vec) -> Vec:
        """[A^H (A f + B dP) + W^H W f ; B^H (A f + B dP) + lambda dP]."""
        fv, dp = v[: self.nb], v[self.nb :]
        geo = self.geo
        r = scores(fv, [zb[None] for zb in self.z], geo)[0]  # A f
        bp = [np.einsum("cd,cyx->dyx", d, xb) for d, xb in zip(dp, self.x)]  # dP^T x
        r = r + scores(self.f0, [q[None] for q in bp], geo)[0]  # + B dP
        out_f = [
            np.conj(zb) * geo.crop(r, b) + reg.apply(fv[b])
            for b, (zb, reg) in enumerate(zip(self.z, self.regs))
        ]
        out_p = [
            _proj_adjoint(xb, f0b, geo.crop(r, b)) + self.proj_reg * d
            for b, (xb, f0b, d) in enumerate(zip(self.x, self.f0, dp))
        ]
        return out_f + out_p

    def rhs(self, yf: Vec, p: list[np.ndarray]) -> Vec:
        """[A^H y ; B^H y - lambda P]."""
        out = [np.conj(zb) * yb for zb, yb in zip(self.z, yf)]
        return out + [
            _proj_adjoint(xb, f0b, yb) - self.proj_reg * pb for xb, f0b, yb, pb in zip(self.x, self.f0, yf, p)
        ]

    def inner(self, a: Vec, b: Vec) -> float:
        nb = self.nb
        return inner(a[:nb], b[:nb]) + sum(float(np.vdot(u, v).real) for u, v in zip(a[nb:], b[nb:]))


def train_joint(
    x: Vec,
    p: list[np.ndarray],
    yf: Vec,
    regs: list[RegOperator],
    geo: Geometry,
    m_diag: Vec,
    proj_reg: float,
    proj_precond: float,
    gn_iter: int,
    cg_iter: int,
) -> tuple[Vec, list[np.ndarray], list[float]]:
    """Gauss-Newton on (f, P) for the first sample x (un-projected half spectra (C, rows, cols) per block),
    from f = 0 and the PCA projection p (ECO eq. 4-7). Returns the filter, the projection matrices and the
    loss after each Gauss-Newton step."""
    nb = len(x)
    total_c = sum(xb.shape[0] for xb in x)
    # reference: proj_precond (2 sum |y^|^2 / sum C + lambda) for every entry of a block's P
    m_p = [np.float32(proj_precond * (2.0 * half_inner(yb, yb) / total_c + proj_reg)) for yb in yf]

    def precond(v: Vec) -> Vec:
        return [vb / mb for vb, mb in zip(v[:nb], m_diag)] + [d / mp for d, mp in zip(v[nb:], m_p)]

    f = [np.zeros((pb.shape[1], *xb.shape[1:]), dtype=np.complex64) for pb, xb in zip(p, x)]
    losses = []
    for _ in range(gn_iter):
        system = _JointSystem(x, p, [fb.copy() for fb in f], regs, geo, proj_reg)
        v0 = f + [np.zeros_like(pb) for pb in p]
        v, _, _ = pcg(
            system.apply,
            system.rhs(yf, p),
            v0,
            precond,
            system.inner,
            cg_iter,
            None,
            1.0,
            fletcher_reeves=True,
        )
        f = [symmetrise(vb) for vb in v[:nb]]
        p = [pb + d.real.astype(np.float32) for pb, d in zip(p, v[nb:])]
        losses.append(joint_loss(x, p, f, yf, regs, geo, proj_reg))
    return f, p, losses


def _proj_adjoint(xb: np.ndarray, f0b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """B^H r for one block: [c, d] = sum over the whole spectrum of Re(conj(x^c f0^d) r) (half: 2 Re - col
    0)."""
    t = np.conj(f0b) * r[None]  # (D, rows, cols)
    full = 2.0 * np.einsum("cyx,dyx->cd", np.conj(xb), t).real
    col0 = np.einsum("cy,dy->cd", np.conj(xb[..., 0]), t[..., 0]).real
    return (full - col0).astype(np.float32)


def filter_loss(
    f: Vec, xs: Vec, weights: np.ndarray, yf: Vec, regs: list[RegOperator], geo: Geometry
) -> float:
    """E(f) of C-COT eq. 10 / ECO eq. 9 (full-spectrum norms), for tests and diagnostics."""
    s = scores(f, xs, geo)
    y = np.zeros((geo.ny, geo.nx), dtype=np.complex64)
    for b, yb in enumerate(yf):
        y[geo.rows[b], : geo.cols[b]] = yb
    data = sum(float(w) * half_inner(s[i] - y, s[i] - y) for i, w in enumerate(weights) if w > 0)
    reg = sum(inner([fb], [r.apply(fb)]) for fb, r in zip(f, regs))
    return data + reg


def joint_loss(
    x: Vec, p: list[np.ndarray], f: Vec, yf: Vec, regs: list[RegOperator], geo: Geometry, proj_reg: float
) -> float:
    """E(f, P) of ECO eq. 4 for one un-projected sample x."""
    z = [np.einsum("cd,cyx->dyx", pb, xb)[None] for pb, xb in zip(p, x)]
    return filter_loss(f, z, np.ones(1), yf, regs, geo) + proj_reg * sum(float(np.sum(pb * pb)) for pb in p)
