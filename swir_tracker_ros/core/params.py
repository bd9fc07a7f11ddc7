# SPDX-License-Identifier: Apache-2.0
"""`TrackerParams`: the flat, documented parameter set of the tracking core (declared as ROS parameters)."""

from __future__ import annotations

from dataclasses import dataclass, fields

from swir_tracker_ros.core.features import FEATURE_KINDS
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param as _f

VARIANTS = ("cf", "kalman", "robust", "robust_adaptive", "robust_adaptive_r")
PIPELINES = ("kcf", "dcf_ca")


@dataclass
class TrackerParams:
    """Every knob of `Tracker`; defaults are published values (paper 000: `kcf`, dissertation: `dcf_ca`).

    Values the papers leave open are marked "(ours)" in their doc string.
    """

    variant: str = _f(
        "robust_adaptive",
        "cf: base filter only; kalman: standard KF + 9 windows + scale + gated "
        "update; robust: Huber k=1.5; robust_adaptive: k from the peak (paper 000 eq. 38 / "
        "dissertation eq. 6.9); robust_adaptive_r: plus adaptive R (dissertation eq. 5.95)",
        choices=VARIANTS,
    )
    pipeline: str = _f(
        "kcf",
        "kcf: paper 000 (KCF, PSR failure detection); dcf_ca: dissertation (DCF-CA, APCE)",
        choices=PIPELINES,
    )
    feature: str = _f(
        "hog_soft",
        "filter features: 31-channel FHOG (cell 4) with soft orientation bins as in Piotr's fhog "
        "(hog_soft, default: better on the real sequences), with hard nearest bins (hog: better on the "
        "synthetic occlusion scenarios; docs/tracking_core.md), or raw gray (cell 1)",
        choices=FEATURE_KINDS,
    )
    cell_size: int = _f(4, "FHOG cell size in pixels (gray features always use 1)", 1, 8)
    kcf_padding: float = _f(1.5, "KCF search window = (1 + padding) x target (paper 000: 2.5x)", 0.5, 4.0)
    kcf_lambda: float = _f(1e-4, "KCF ridge regularisation lambda (eq. 1)", 1e-8, 1.0)
    kcf_kernel_sigma: float = _f(
        0.5, "KCF Gaussian kernel sigma (eq. 7); 0.2 is the raw-gray value", 0.01, 10.0
    )
    kcf_interp_factor: float = _f(0.02, "KCF model learning rate; 0.075 is the raw-gray value", 0.0, 1.0)
    dcf_padding: float = _f(2.0, "DCF-CA window = (1 + padding) x target (3x)", 0.5, 4.0)
    dcf_lambda1: float = _f(1e-4, "DCF-CA ridge regularisation lambda1", 1e-8, 1.0)
    dcf_lambda2: float = _f(25.0, "DCF-CA context regularisation lambda2", 0.0, 1000.0)
    dcf_interp_factor: float = _f(0.015, "DCF-CA learning rate delta (eq. 4.92)", 0.0, 1.0)
    dcf_reference_peak: float = _f(
        0.55,
        "(ours) DCF-CA responses are scaled so the first-frame self-response peaks at this value; it puts "
        "the tracking peaks at the dissertation's 0.2-0.29 (Fig. 4.6), the range eq. 6.9 expects; 0: raw",
        0.0,
        10.0,
    )
    output_sigma_factor: float = _f(0.1, "Gaussian label sigma = sqrt(w h) x factor / cell", 0.01, 1.0)
    scale_step: float = _f(0.05, "relative size step of the scale samples (paper 000: 5 %)", 0.0, 0.3)
    n_scales: int = _f(5, "scale samples around the predicted size (1, 3 or 5)", 1, 5)
    large_target_halving: float = _f(
        100.0,
        "model works at half resolution when sqrt(w h) >= this many pixels (KCF reference); 0 disables",
        0.0,
        10000.0,
    )
    psr_threshold: float = _f(
        7.0, "KCF failure detection: PSR below this switches to 9 windows (paper 000)", 0.0, 100.0
    )
    psr_exclusion_px: int = _f(
        10,
        "side of the square around the peak excluded from the PSR sidelobe, in "
        "template pixels (paper 000: 10x10); ceil(px / cell) response cells",
        1,
        100,
    )
    update_peak_threshold: float = _f(
        0.5, "KCF: model updated only when the peak exceeds this (paper 000)", 0.0, 2.0
    )
    apce_occlusion_ratio: float = _f(
        0.6, "DCF-CA: occlusion when APCE <= ratio x mean APCE (eq. 4.96)", 0.0, 2.0
    )
    apce_update_ratio: float = _f(
        0.583, "DCF-CA: no model update when APCE <= ratio x mean (eq. 4.97)", 0.0, 2.0
    )
    fixed_huber_threshold: float = _f(1.5, "Huber threshold of the `robust` variant", 0.05, 10.0)
    robust_method: str = _f(
        "auto",
        "statistical linearisation of the robust update; auto: A4 for kcf "
        "(paper 000 eq. 33-35), A2 for dcf_ca (dissertation eq. 5.52)",
        choices=("auto", "A2", "A4"),
    )
    grid_overlap: float = _f(
        1.0 / 3.0, "overlap of neighbouring re-detection windows (paper 000: 1/3)", 0.0, 0.9
    )
    grid_scale_search: bool = _f(
        False,
        "also search the 5 scales in each of the 9 windows (paper 000 text); "
        "off: KF size during re-detection (dissertation), 5x cheaper",
    )
    max_occluded_frames: int = _f(
        150, "(ours) frames in re-detection before the state becomes lost", 1, 100000
    )
    stretch: str = _f(
        "auto",
        "intensity stretch: auto (16-bit and float by percentiles), always, off",
        choices=("auto", "always", "off"),
    )
    stretch_low_percentile: float = _f(0.5, "black level percentile of the stretch", 0.0, 49.0)
    stretch_high_percentile: float = _f(99.5, "white level percentile of the stretch", 51.0, 100.0)
    stretch_smoothing: float = _f(0.8, "(ours) EMA weight of the previous stretch limits", 0.0, 0.99)
    dead_pixel_threshold: float = _f(
        0.0, "replace pixels further than this (0..1) from their 3x3 median; 0: off", 0.0, 1.0
    )
    deinterlace: str = _f(
        "off", "use one field of interlaced frames, line-doubled", choices=("off", "even", "odd")
    )
    downscale: float = _f(
        1.0, "resize frames by this factor before tracking (boxes stay in input pixels)", 0.1, 1.0
    )

    def validate(self) -> None:
        """Raise ParameterError naming the first field whose value is of the wrong type or out of range."""
        for f in fields(self):
            v = getattr(self, f.name)
            meta = f.metadata
            expected = {"str": str, "int": int, "float": (int, float), "bool": bool}[str(f.type)]
            if (isinstance(v, bool) and str(f.type) != "bool") or not isinstance(v, expected):
                raise ParameterError(f"TrackerParams.{f.name} = {v!r} has the wrong type; expected {f.type}")
            if "choices" in meta and v not in meta["choices"]:
                raise ParameterError(f"TrackerParams.{f.name} = {v!r} is not one of {meta['choices']}")
            if "min" in meta and not (meta["min"] <= v <= meta["max"]):
                raise ParameterError(
                    f"TrackerParams.{f.name} = {v!r} is outside [{meta['min']}, {meta['max']}]"
                )
        if self.n_scales not in (1, 3, 5):
            raise ParameterError(f"TrackerParams.n_scales = {self.n_scales} must be 1, 3 or 5")
        if self.stretch_low_percentile >= self.stretch_high_percentile:
            raise ParameterError("TrackerParams.stretch_low_percentile must be below stretch_high_percentile")

    def scale_factors(self) -> tuple[float, ...]:
        """Relative sizes searched in normal mode, e.g. (0.90, 0.95, 1, 1.05, 1.10)."""
        half = self.n_scales // 2
        return tuple(1.0 + self.scale_step * i for i in range(-half, half + 1))
