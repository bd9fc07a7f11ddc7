# SPDX-License-Identifier: Apache-2.0
"""`ECOFilter`: the ECO base filter (Danelljan et al., CVPR 2017) with a surface a long-term layer can drive.

    filt = ECOFilter(ECOParams())
    filt.init(frame, box)                  # frame: float32 (H, W) in [0, 1]
    det = filt.detect(frame)               # at the current position and size (or center=, size=)
    filt.update(frame, det, learn=True)    # move there; learn=False: move without teaching the model
    dets = filt.detect_windows(frame, centers)   # extra windows at the current size (re-detection)

Per frame: the image sample at the current position is resampled to the support, its feature blocks are
compressed by P (ECO eq. 3), windowed and interpolated to the continuous domain (C-COT eq. 4); the score is
sum_d f^d z^d per frequency, maximised on the grid and refined by Newton (core/eco/localise.py); the size
follows from the fDSST scale filter (ECO-HC), or stays (`scale_estimator` none). A frame that teaches
the model adds its detection sample, shifted so that the target is centred, to the sample space (ECO Sec.
3.2); every N_S-th frame (every frame before `skip_after_frame`) N_CG warm-started CG iterations update the
filter (ECO Sec. 3.3). The first frame learns P and f jointly by Gauss-Newton (ECO eq. 4-7).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

import swir_tracker_ros.core.eco.features as feat
import swir_tracker_ros.core.eco.optimise as opt
from swir_tracker_ros.core.eco.fourier import gaussian_label, half_size, shift_phase
from swir_tracker_ros.core.eco.geometry import SampleGeometry, sample_geometry
from swir_tracker_ros.core.eco.localise import localise
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.core.eco.regularisation import RegOperator, reg_window_spectrum, squared_kernel
from swir_tracker_ros.core.eco.sample_space import SampleSpace
from swir_tracker_ros.core.features import sample_patch
from swir_tracker_ros.core.scale import DSSTParams, ScaleFilter
from swir_tracker_ros.errors import TrackerError
from swir_tracker_ros.types import Box


@dataclass(frozen=True)
class ECODetection:
    """One detection: target centre and size (image px), the size factor against the size searched, the
    score's peak, PSR and APCE, the image region searched. `sample` (projected half spectra of the searched
    sample that won) and `extent` (image px of one period) let `update` learn from it."""

    cx: float
    cy: float
    w: float
    h: float
    scale: float
    peak: float
    psr: float
    apce: float
    window: Box
    sample: list[np.ndarray] = field(repr=False, compare=False)
    extent: tuple[float, float] = field(repr=False, compare=False)

    @property
    def box(self) -> Box:
        return Box.from_center(self.cx, self.cy, self.w, self.h)


def dsst_params(p: ECOParams) -> DSSTParams:
    """The fDSST scale filter of ECO-HC as core/scale.py's DSST: 17 samples spanning the 33 interpolated
    scales (step 1.02^(33/17)), label sigma 33/16 interpolated steps, response interpolated 8 points a
    step."""
    ratio = p.scale_filter_interp / p.scale_filter_scales
    sigma_steps = p.scale_filter_interp * p.scale_sigma_factor / ratio
    return DSSTParams(
        n_scales=p.scale_filter_scales,
        scale_step=p.scale_filter_step**ratio,
        sigma_factor=sigma_steps / math.sqrt(p.scale_filter_scales),
        lambda_=p.scale_lambda,
        learning_rate=p.scale_learning_rate,
        model_max_area=p.scale_model_max_area,
        interpolation=8,
    )


class ECOFilter:
    """ECO base filter (module docstring). State: `center`, `scale_factor`, `box`, `frame`."""

    def __init__(self, params: ECOParams | None = None) -> None:
        self.params = params if params is not None else ECOParams()
        self.params.validate()

    # --- set-up -------------------------------------------------------------------------------------------

    def init(self, frame: np.ndarray, box: Box) -> None:
        """Learn the projection and the filter from `box` on the first frame (ECO eq. 4-7)."""
        if not box.is_valid() or box.w < 2 or box.h < 2:
            raise TrackerError(f"ECO needs a target of at least 2x2 pixels, got {box}")
        p = self.params
        g = sample_geometry(box.w, box.h, p)
        self.geo: SampleGeometry = g
        self.center = (box.cx, box.cy)
        self.scale_factor = g.scale
        ih, iw = frame.shape[:2]
        step = p.scale_filter_step
        self.min_scale = step ** math.ceil(
            math.log(max(5.0 / g.support[0], 5.0 / g.support[1])) / math.log(step)
        )
        self.max_scale = step ** math.floor(math.log(min(ih / g.base[0], iw / g.base[1])) / math.log(step))
        shapes = [g.grid(b) for b in range(len(g.blocks))]
        self.ks = [(half_size(n), half_size(m)) for n, m in shapes]
        self.out = opt.Geometry([(2 * ky + 1, kx + 1) for ky, kx in self.ks])
        sigma = math.sqrt(math.floor(g.base[0]) * math.floor(g.base[1])) * p.output_sigma_factor
        kmax = max(self.ks)
        y = gaussian_label(kmax[0], kmax[1], sigma, sigma, (float(g.support[0]), float(g.support[1])))
        self.yf = [self.out.crop(y, b) for b in range(len(shapes))]
        wf = reg_window_spectrum(
            g.support, g.base, p.reg_window_min, p.reg_window_edge, p.reg_window_power, p.reg_sparsity
        )
        w2 = squared_kernel(wf)
        self.regs = [RegOperator(w2, ky, kx) for ky, kx in self.ks]
        # first sample: un-projected blocks, PCA projection, joint Gauss-Newton (ECO eq. 4-7)
        raw = feat.extract(self._patches(frame, self.center, [1.0]), g.blocks)
        self.proj = [feat.pca_projection(x[0], s.dim) for x, s in zip(raw, g.blocks)]
        xf = [x[0] for x in feat.spectra(raw, p.interp_a)]
        energy0 = [np.abs(feat.project(x, pb)) ** 2 for x, pb in zip(xf, self.proj)]
        m_diag = opt.preconditioner(energy0, self.regs, p.precond_data, p.precond_reg)
        cg = max(1, math.ceil(p.init_cg_iter / p.init_gn_iter))
        self.hf, self.proj, self.init_losses = opt.train_joint(
            xf,
            self.proj,
            self.yf,
            self.regs,
            self.out,
            m_diag,
            p.projection_reg,
            p.precond_proj,
            p.init_gn_iter,
            cg,
        )
        z = [feat.project(x, pb) for x, pb in zip(xf, self.proj)]
        self.space = SampleSpace([zb.shape for zb in z], p.n_samples, p.learning_rate)
        self.space.add(z)
        self.energy = [np.abs(zb) ** 2 for zb in z]
        self.cg_state: opt.CGState | None = None
        self.frame = 1
        self.since_train = 0
        self.scale_filter: ScaleFilter | None = None
        if p.scale_estimator == "dsst":
            self.scale_filter = ScaleFilter(dsst_params(p), box.w, box.h, soft=p.hog_soft)
            self.scale_filter.train(frame, box.cx, box.cy, box.w, box.h, 1.0)

    # --- state --------------------------------------------------------------------------------------------

    @property
    def size(self) -> tuple[float, float]:
        """(w, h) of the target in image pixels."""
        return self.geo.base[1] * self.scale_factor, self.geo.base[0] * self.scale_factor

    @property
    def box(self) -> Box:
        w, h = self.size
        return Box.from_center(self.center[0], self.center[1], w, h)

    def set_target(self, cx: float, cy: float, w: float | None = None) -> None:
        """Move the state (e.g. to a long-term layer's estimate); w: new width (the aspect is kept)."""
        self.center = (cx, cy)
        if w is not None:
            self.scale_factor = self._clamp(w / self.geo.base[1])

    def _clamp(self, s: float) -> float:
        return min(max(s, self.min_scale), self.max_scale)

    # --- detection ----------------------------------------------------------------------------------------

    def _patches(self, frame: np.ndarray, center: tuple[float, float], mults: list[float]) -> np.ndarray:
        """Image samples (len(mults), rows, cols) float32 centred on `center`, support x scale x each
        factor."""
        sy, sx = self.geo.support
        out = np.empty((len(mults), sy, sx), dtype=np.float32)
        for i, m in enumerate(mults):
            s = self.scale_factor * m
            sample_patch(frame, Box.from_center(center[0], center[1], sx * s, sy * s), sx, sy, out=out[i])
        return out

    def _project(self, raw: list[np.ndarray]) -> list[np.ndarray]:
        return feat.spectra([feat.project(x, pb) for x, pb in zip(raw, self.proj)], self.params.interp_a)

    def _score(self, z: list[np.ndarray]) -> np.ndarray:
        return opt.scores(self.hf, z, self.out)

    def _exclusion(self) -> int:
        """PSR exclusion zone in response cells (`psr_exclusion` x the target, at least 3, odd)."""
        cell = self.geo.support[1] / (2 * max(self.ks)[1] + 1)
        n = self.params.psr_exclusion * math.sqrt(self.geo.base[0] * self.geo.base[1]) / cell
        return max(3, 2 * round(n / 2) + 1)

    def detect(
        self,
        frame: np.ndarray,
        center: tuple[float, float] | None = None,
        scale_factor: float | None = None,
        estimate_scale: bool = True,
    ) -> ECODetection:
        """Translation (and size) of the target in a sample at `center` (default: the current position), at
        the current size or `scale_factor` (image px per sample px); the state is not changed."""
        c = self.center if center is None else center
        s0 = self.scale_factor if scale_factor is None else scale_factor
        saved, self.scale_factor = self.scale_factor, s0
        try:
            raw = feat.extract(self._patches(frame, c, [1.0]), self.geo.blocks)
        finally:
            self.scale_factor = saved
        z = self._project(raw)
        i, peak, _, _ = localise(self._score(z), self.params.newton_iterations, self._exclusion())
        ey, ex = self.geo.support[0] * s0, self.geo.support[1] * s0
        cx, cy = c[0] + peak.tx * ex, c[1] + peak.ty * ey
        factor = 1.0
        if estimate_scale and self.scale_filter is not None:
            w, h = self.geo.base[1] * s0, self.geo.base[0] * s0
            factor = self.scale_filter.estimate(frame, cx, cy, w, h)
        s = self._clamp(s0 * factor)
        window = Box.from_center(c[0], c[1], ex, ey)
        sample = [zb[i] for zb in z]
        return ECODetection(
            cx,
            cy,
            self.geo.base[1] * s,
            self.geo.base[0] * s,
            s / s0,
            peak.value,
            peak.psr,
            peak.apce,
            window,
            sample,
            (ey, ex),
        )

    def detect_windows(self, frame: np.ndarray, centers: list[tuple[float, float]]) -> list[ECODetection]:
        """One detection per window centre at the current size, features of all windows in one batch; no
        scale estimate (the re-detection search of a long-term layer)."""
        if not centers:
            return []
        sy, sx = self.geo.support
        s = self.scale_factor
        patches = np.empty((len(centers), sy, sx), dtype=np.float32)
        for i, (cx, cy) in enumerate(centers):
            sample_patch(frame, Box.from_center(cx, cy, sx * s, sy * s), sx, sy, out=patches[i])
        z = self._project(feat.extract(patches, self.geo.blocks))
        sf = self._score(z)
        out = []
        w, h = self.size
        for i, (cx, cy) in enumerate(centers):
            _, peak, _, _ = localise(sf[i : i + 1], self.params.newton_iterations, self._exclusion())
            ey, ex = sy * s, sx * s
            out.append(
                ECODetection(
                    cx + peak.tx * ex,
                    cy + peak.ty * ey,
                    w,
                    h,
                    1.0,
                    peak.value,
                    peak.psr,
                    peak.apce,
                    Box.from_center(cx, cy, ex, ey),
                    [zb[i] for zb in z],
                    (ey, ex),
                )
            )
        return out

    # --- update -------------------------------------------------------------------------------------------

    def update(
        self,
        frame: np.ndarray,
        det: ECODetection,
        learn: bool = True,
        center: tuple[float, float] | None = None,
    ) -> None:
        """Move to the detection (or to `center` with the detection's size) and, if `learn`, add its sample
        centred there to the sample space and optimise on schedule (ECO Sec. 3.2-3.3)."""
        c = (det.cx, det.cy) if center is None else center
        self.center = c
        self.scale_factor = self._clamp(det.w / self.geo.base[1])
        if not learn:
            return
        p = self.params
        ty = (c[1] - det.window.cy) / det.extent[0]
        tx = (c[0] - det.window.cx) / det.extent[1]
        z = [
            zb * shift_phase(ky, kx, 2 * math.pi * ty, 2 * math.pi * tx)
            for zb, (ky, kx) in zip(det.sample, self.ks)
        ]
        self.space.add(z)
        self.frame += 1
        if self.frame < p.skip_after_frame or self.since_train >= p.train_gap:
            lr = p.learning_rate
            self.energy = [(1.0 - lr) * e + lr * np.abs(zb) ** 2 for e, zb in zip(self.energy, z)]
            m_diag = opt.preconditioner(self.energy, self.regs, p.precond_data, p.precond_reg)
            forget = 0.0 if p.cg_forgetting_rate == math.inf else (1.0 - lr) ** p.cg_forgetting_rate
            n = self.space.count
            self.hf, self.cg_state, _ = opt.train_filter(
                self.hf,
                [s[:n] for s in self.space.samples],
                self.space.weights[:n],
                self.yf,
                self.regs,
                self.out,
                m_diag,
                p.cg_iter,
                self.cg_state,
                forget,
            )
            self.since_train = 0
        else:
            self.since_train += 1
        if self.scale_filter is not None:
            w, h = self.size
            self.scale_filter.train(frame, c[0], c[1], w, h, self.params.scale_learning_rate)
