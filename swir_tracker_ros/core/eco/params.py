# SPDX-License-Identifier: Apache-2.0
"""`ECOParams`: every setting of the ECO base filter, each default written once here.

Where a value is the ECO-HC reference configuration's it says so: "ECO-HC" is the authors' MATLAB
configuration `runfiles/OTB_HC_settings.m` of martin-danelljan/ECO (version 2.0), the values behind the
paper's
hand-crafted tracker (Danelljan et al., CVPR 2017); the public Python port StrangerZhang/pyECO (its
`otb_hc_config.py`, the peer in ../shared/peers/ecohc_py) differs in output sigma (1/14) and in the
first-frame
iterations (5 Gauss-Newton x 15 CG). Values marked "(ours)" are this project's, each measured on both folds
(docs/eco.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.confidence import PSR_FAILURE
from swir_tracker_ros.core.scale import DSSTParams
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params


@dataclass
class ECOParams(FilterParams):
    """ECO base filter (ECO, CVPR 2017; C-COT, ECCV 2016); see docs/eco.md."""

    # image sample (ECO-HC)
    search_area_scale: float = _f(
        4.0, "image sample = this x the target (area ratio squared; ECO-HC 4)", 1.5, 10.0
    )
    search_area_shape: str = _f(
        "square",
        "square (ECO-HC: side sqrt(w h) x scale) or proportional",
        choices=("square", "proportional"),
    )
    min_search_side: float = _f(
        64.0,
        "(ours) the image sample's side is at least this many image pixels: a small target (sqrt(w h) < 16 "
        "px here) gets a wider search area, e.g. a 10 x 8 px drone 7x instead of 4x; 0: off",
        0.0,
        2000.0,
    )
    min_sample_size: int = _f(
        150, "smaller samples are resampled up to this side (px; ECO-HC 150^2 area)", 24, 1000
    )
    max_sample_size: int = _f(
        200, "larger samples are resampled down to this side (px; ECO-HC 200^2 area)", 24, 1000
    )
    # features (ECO-HC gray: FHOG cell 6 -> 10 dims, intensity channels cell 4 -> 3 dims)
    hog_cell: int = _f(6, "FHOG cell in sample pixels (ECO-HC 6)", 2, 16)
    hog_soft: bool = _f(
        False,
        "FHOG orientation binning: soft (linear between the two nearest of 18 bins, core/fhog.py "
        "'hog_soft') or hard (nearest bin: Piotr Dollar's fhog with softBin -1, which ECO-HC's features "
        "call, interpolates in space only); the translation and the scale filter's FHOG",
    )
    hog_dim: int = _f(10, "FHOG channels after the projection P (ECO-HC 10 of 31)", 1, 31)
    intensity_cell: int = _f(
        4, "intensity channels' cell in sample pixels (ECO-HC 4); 0: no intensity block", 0, 16
    )
    intensity_dim: int = _f(3, "intensity channels after the projection (ECO-HC 3)", 1, 32)
    intensity_bins: int = _f(
        4,
        "soft intensity histogram bins besides the cell mean (ours: 1 + 4 channels stand in for the 5 of "
        "ECO-HC's "
        "lookup table intensityChannelNorm6)",
        0,
        31,
    )
    # learning (ECO-HC)
    output_sigma_factor: float = _f(1.0 / 16.0, "label sigma = sqrt(w h) x this (ECO-HC 1/16)", 0.01, 1.0)
    learning_rate: float = _f(0.009, "gamma, weight of a new sample (ECO-HC 0.009)", 0.0, 1.0)
    n_samples: int = _f(30, "L, components of the sample space model (ECO-HC 30)", 1, 200)
    train_gap: int = _f(5, "frames without optimisation between two (N_S - 1; ECO-HC 5)", 0, 100)
    skip_after_frame: int = _f(10, "optimise on every frame before this one (ECO-HC 10)", 1, 1000)
    cg_iter: int = _f(5, "N_CG, CG iterations of an update (ECO-HC 5)", 1, 100)
    cg_forgetting_rate: float = _f(
        50.0, "the last direction is kept with weight (1 - gamma)^this (ECO-HC 50)", 0.0, 1e6
    )
    precond_data: float = _f(
        0.75, "preconditioner: weight of the channel's own energy (ECO-HC 0.75)", 0.0, 1.0
    )
    precond_reg: float = _f(
        0.25, "preconditioner: weight of the regularisation energy (ECO-HC 0.25)", 0.0, 1.0
    )
    # factorised convolution, first frame (ECO-HC)
    projection_reg: float = _f(1e-7, "lambda of ||P||^2 (ECO-HC 1e-7)", 0.0, 1.0)
    init_gn_iter: int = _f(10, "Gauss-Newton iterations on the first frame (ECO-HC 10)", 1, 100)
    init_cg_iter: int = _f(150, "CG iterations on the first frame in all (ECO-HC 10 x 15)", 1, 2000)
    precond_proj: float = _f(40.0, "preconditioner weight of P (ECO-HC 40)", 1e-6, 1e6)
    # spatial regularisation (ECO-HC)
    reg_window_min: float = _f(1e-4, "w on the target (ECO-HC 1e-4)", 1e-8, 1.0)
    reg_window_edge: float = _f(10e-3, "w at the target's edge (ECO-HC 10e-3)", 1e-8, 10.0)
    reg_window_power: float = _f(2.0, "w grows with the distance to this power (ECO-HC 2)", 1.0, 8.0)
    reg_sparsity: float = _f(
        0.05, "w^ coefficients below this x the largest are dropped (ECO-HC 0.05)", 0.0, 1.0
    )
    # interpolation and localisation (ECO-HC)
    interp_a: float = _f(-0.75, "a of the cubic interpolation kernel (ECO-HC -0.75)", -2.0, 0.0)
    newton_iterations: int = _f(5, "Newton iterations on the score (ECO-HC 5)", 0, 50)
    # scale
    scale_estimator: str = _f(
        "dsst", "dsst: fDSST scale filter after the translation (ECO-HC); none: fixed size",
        choices=("dsst", "none"),
    )
    scale_filter_scales: int = _f(17, "fDSST scales sampled (ECO-HC 17)", 3, 65)
    scale_filter_interp: int = _f(33, "fDSST response interpolated to this many scales (ECO-HC 33)", 3, 257)
    scale_filter_step: float = _f(
        DSSTParams.scale_step, "fDSST step between interpolated scales (ECO-HC: DSST's 1.02)", 1.001, 1.2
    )
    scale_sigma_factor: float = _f(
        1.0 / 16.0, "fDSST label sigma = interp scales x this (ECO-HC 1/16)", 0.01, 1.0
    )
    scale_learning_rate: float = _f(
        DSSTParams.learning_rate, "fDSST learning rate (ECO-HC: DSST's 0.025)", 0.0, 1.0
    )
    scale_lambda: float = _f(DSSTParams.lambda_, "fDSST regularisation (ECO-HC: DSST's 1e-2)", 1e-8, 10.0)
    scale_model_max_area: int = _f(
        2000,
        "fDSST samples resampled to at most this area (ECO-HC 32 x 16 = 512; ours 2000: with 512 the size "
        "drifts on tall targets)",
        64,
        10000,
    )
    # confidence of the response (ours)
    psr_exclusion: float = _f(
        0.5,
        "PSR excludes a square of this x the target's size around the peak (>= 3 response cells)",
        0.0,
        4.0,
    )

    # the long-term layer's test on the response (core/eco/base.py)
    failure_psr: float = _f(
        PSR_FAILURE,
        "failure (occlusion) test of a detection: PSR (psr_exclusion) below this, paper 000's threshold; "
        "the model learns only from frames that pass it. The continuous peak is no target-independent "
        "test (a small drone is tracked at a fraction of a pedestrian's peak), the PSR on the target is; 0: "
        "off",
        0.0,
        1000.0,
    )
    failure_psr_ratio: float = _f(
        0.35,
        "(ours) failure also when the PSR falls below this x the mean PSR of the last failure_psr_window "
        "frames that taught the filter (a relative test, as the dissertation's APCE test, eq. 4.96): an "
        "occluder or a pole keeps ECO's PSR just over 7; the recent mean, not that of every frame since "
        "the start, so that a target whose PSR declines slowly is not failed; 0: off",
        0.0,
        1.0,
    )
    failure_psr_window: int = _f(
        30, "(ours) the last taught frames whose PSRs make failure_psr_ratio's mean (about a second)", 1,
        100000)

    def validate(self) -> None:
        validate_params(self, "eco.")

    def check(self) -> None:
        if self.min_sample_size > self.max_sample_size:
            raise ParameterError("parameter eco.min_sample_size must not exceed eco.max_sample_size")
        if self.scale_filter_scales % 2 == 0:
            raise ParameterError(
                f"parameter eco.scale_filter_scales = {self.scale_filter_scales} must be odd"
            )
