# SPDX-License-Identifier: Apache-2.0
"""`TrackerParams`: the one documented parameter set of the tracking core (declared as ROS parameters).

Per-filter settings are nested dataclasses (`kcf: KCFParams`, ...): ROS names `tracker.kcf.padding`, ...
"""

from __future__ import annotations

from dataclasses import dataclass, field

from swir_tracker_ros.core.bacf import BACFParams
from swir_tracker_ros.core.dcf_ca import DCFCAParams
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.kalman.influence import HUBER_K
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params

VARIANTS = ("cf", "kalman", "robust", "robust_adaptive", "robust_adaptive_r", "measured")
PIPELINES = ("kcf", "dcf_ca", "bacf")


@dataclass
class TrackerParams:
    """Every knob of `Tracker`; defaults are published values (paper 000: `kcf`, dissertation: `dcf_ca`).

    Values the papers leave open are marked "(ours)" in their doc string.
    """

    variant: str = _f(
        "measured",
        "cf: base filter only; kalman: standard KF + 9 windows + scale + gated "
        "update; robust: Huber k=1.5; robust_adaptive: k from the peak (paper 000 eq. 38 / "
        "dissertation eq. 6.9); robust_adaptive_r: plus adaptive R (dissertation eq. 5.95); measured "
        "(ours, default): robust_adaptive, but a confident frame reports and searches from the correlation "
        "peak itself (no posterior lag) and a long-term memory verifies every tracking frame "
        "(docs/tracking_core.md)",
        choices=VARIANTS,
    )
    pipeline: str = _f(
        "kcf",
        "kcf: paper 000 (KCF, PSR failure detection); dcf_ca: dissertation (DCF-CA, APCE); bacf: "
        "background-aware correlation filter (Kiani Galoogahi et al., ICCV 2017) with kcf's failure test",
        choices=PIPELINES,
    )
    kcf: KCFParams = field(
        default_factory=KCFParams, metadata={"doc": "paper 000 KCF pipeline (core/kcf.py KCFParams)"}
    )
    dcf_ca: DCFCAParams = field(
        default_factory=DCFCAParams, metadata={"doc": "dissertation DCF-CA pipeline (core/dcf_ca.py)"}
    )
    bacf: BACFParams = field(
        default_factory=BACFParams, metadata={"doc": "background-aware CF pipeline (core/bacf.py BACFParams)"}
    )
    scale_step: float = _f(0.05, "relative size step of the scale samples (paper 000: 5 %)", 0.0, 0.3)
    n_scales: int = _f(5, "scale samples around the predicted size (1, 3 or 5)", 1, 5)
    scale_penalty: float = _f(
        0.95,
        "(ours, variant measured) the peak of a scale sample k steps from the predicted size is weighted by "
        "this^|k| when the "
        "best scale is picked (the scale_weight 0.95 of the KCF C++ reference implementation, KCFcpp): a "
        "larger window that takes in more of the target's surroundings must beat the predicted size by "
        "more than its peak noise; 1 (and the papers' variants): the largest peak",
        0.5,
        1.0,
    )
    scale_climb: bool = _f(
        True,
        "(ours, variant measured) normal mode correlates the 3 middle scale samples and goes outward one at "
        "a time only while the outermost one is the best (penalised peaks): the same pick as the full "
        "search on all but a few frames, at 3-3.6 windows a frame instead of 5 (docs/speed.md); off (and "
        "the papers' variants, and while re-detecting): every sample",
    )
    scale_climb_ratio: float = _f(
        0.9,
        "(ours, scale_climb) a frame whose best peak of the climb is below this x the mean peak of the "
        "tracked frames (and every frame before the first tracked one) correlates every scale sample",
        0.0,
        2.0,
    )
    large_target_halving: float = _f(
        100.0,
        "model works at half resolution when sqrt(w h) >= this many pixels (KCF reference); 0 disables",
        0.0,
        10000.0,
    )
    psr_exclusion_px: int = _f(
        10,
        "side of the square around the peak excluded from the PSR sidelobe, in "
        "template pixels (paper 000: 10x10); ceil(px / cell) response cells",
        1,
        100,
    )
    fixed_huber_threshold: float = _f(HUBER_K, "Huber threshold of the `robust` variant", 0.05, 10.0)
    robust_method: str = _f(
        "auto",
        "statistical linearisation of the robust update; auto: A4 for kcf and bacf "
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
    redetect_peak_ratio: float = _f(
        0.6,
        "(ours, variant measured) re-acquisition needs a peak of at least this ratio of the mean peak of "
        "the tracked frames: a weaker peak in a window away from the prediction is no measurement (the "
        "filter coasts), and a weaker first non-failed frame after an occlusion stays `occluded`; 0: off",
        0.0,
        2.0,
    )
    size_rate_peak_ratio: float = _f(
        0.6,
        "(ours, variant measured) a tracked frame whose peak is below this ratio of the tracked peaks' mean "
        "zeroes the size velocity before its Kalman update: the sizes of weak, changing responses (a target "
        "that turns) are measured but not extrapolated, so the box no longer shrinks away frame after frame "
        "(VOT-TIR horse, OTB girl: docs/tracking_core.md, ninth pass); 0: off (the papers)",
        0.0,
        2.0,
    )
    redetect_psr: float = _f(
        12.0,
        "(ours, variant measured) re-acquisition also needs a PSR of at least this, a hysteresis over the "
        "failure test's PSR 7: a first non-failed frame after an occlusion below it stays `occluded` (a "
        "static edge of the occluder was taken back at PSR 7-12, its peak and memory score just over their "
        "bars: synthetic x_low_contrast_interlaced; docs/tracking_core.md, ninth pass); pipeline kcf only "
        "(BACF's flatter responses keep PSRs near 7 on the target); 0: off",
        0.0,
        100.0,
    )
    lattice_step: float = _f(
        0.35,
        "(ours, variant measured) re-detection searches a lattice of windows this fraction of a window "
        "apart instead of the papers' 3x3 grid (steps of 1 - grid_overlap leave gaps a displaced target's "
        "cosine-windowed response cannot bridge); 0: the 3x3 grid",
        0.0,
        1.0,
    )
    lattice_rings: int = _f(
        2, "(ours) rings of the re-detection lattice around the prediction at the start of an occlusion "
        "(2: 5x5 windows)", 1, 10
    )
    lattice_widen_frames: int = _f(
        25,
        "(ours) one more ring every this many frames since the last confident frame, up to "
        "lattice_max_rings (windows outside the image are skipped); 0: no widening",
        0,
        100000,
    )
    lattice_max_rings: int = _f(3, "(ours) widest re-detection lattice (3: 7x7 windows)", 1, 10)
    sweep_after: int = _f(
        25,
        "(ours, variant measured) frames of re-detection after which every frame that is not `tracking` "
        "also searches one tile of a sweep over the whole image (a lattice_rings lattice, its centre "
        "included; each pass from the tile nearest the prediction outwards), and a prediction that left "
        "the image is held at its "
        "border instead of ending the track: a target that turned back or stopped while hidden is found "
        "where the pre-occlusion motion cannot put it (synthetic t2, x_low_contrast_interlaced). The "
        "box moves to a tile's peak only when it and a window centred on it pass the re-acquisition bars "
        "(redetect_peak_ratio, redetect_psr; LCT's re-detection, Ma et al. CVPR 2015 Sec. 3.4); the "
        "state turns `tracking` on the next frame's usual checks; pipeline kcf only; 0: off",
        0,
        100000,
    )
    sweep_filter: str = _f(
        "memory",
        "(ours, variant measured) what the long-loss sweep correlates: 'memory' the long-term memory, "
        "trained on confident frames only (the bars relative to its mean peak); 'filter' the tracking "
        "filter (the bars relative to its tracked mean, plus the memory's check at memory_ratio); both "
        "measured alike (docs/tracking_core.md, twelfth pass)",
        choices=("memory", "filter"),
    )
    lattice_channels: int = _f(
        8,
        "(ours) the re-detection lattice is screened with the filter projected on this many principal "
        "channel directions of its model (the PCA feature compression of fDSST, Danelljan et al. TPAMI 2017) "
        "and only the 3 best screened windows are correlated in full (KCF filters; the scores within their "
        "noise, occlusion mode faster: docs/tracking_core.md, eighth pass); 0: every window in full",
        0,
        64,
    )
    lattice_alternate: int = _f(
        2,
        "(ours) the lattice's rings from this one outwards are searched as a checkerboard whose two halves "
        "alternate frame to frame (the windows inside it every frame): from ring 2 a 7x7 lattice "
        "correlates 28 windows a frame instead of 48, from ring 1 24 (which lost a synthetic occlusion); "
        "a far target is found at most one frame later; 0: every window every frame",
        0,
        10,
    )
    redetect_prior: float = _f(
        1.0,
        "(ours, variant measured) re-detection picks the window whose peak x exp(-d^2 / 2 sigma^2) is "
        "largest, d the distance of its peak from the prediction and sigma this factor x the lattice's "
        "half-width (it widens with the lattice): a look-alike far away must beat the target's weaker "
        "peak near the prediction by more than the distance costs; 0: the largest peak",
        0.0,
        10.0,
    )
    coast_velocity_decay: float = _f(
        1.0,
        "(ours, variant measured) per-frame factor on the centre velocity while re-detecting: 1 holds the "
        "pre-occlusion motion (the papers' premise); below 1 the prediction slows down and stays near where "
        "the target was last seen while the lattice widens around it",
        0.0,
        1.0,
    )
    redetect_rescan: bool = _f(
        False,
        "(ours, variant measured) while re-detecting, a non-failed but weak peak at the prediction (below "
        "redetect_peak_ratio x the tracked mean) keeps the lattice search going instead of steering the "
        "filter as a normal-mode measurement",
    )
    redetect_scales: float = _f(
        1.2,
        "(ours, variant measured) while re-detecting, the scale search at the prediction gets two more "
        "windows, at this factor and its inverse times the predicted size (penalised by scale_penalty as "
        "the next scale steps): a size that shrank while the target was not recognised (a turn, a partial "
        "occlusion) can grow back; 0: off (the n_scales search only)",
        0.0,
        3.0,
    )
    coast_frames: int = _f(
        0,
        "(ours, variant measured) frames of re-detection after which the centre velocity is set to zero: "
        "the pre-occlusion motion carries the prediction through a short occlusion, a longer one is "
        "searched around where the prediction stands (the lattice keeps widening); 0: never",
        0,
        100000,
    )
    coast_velocity_window: int = _f(
        50,
        "(ours, variant measured) when tracking turns to re-detection, the centre velocity becomes the "
        "mean velocity of the tracked centre over this many frames before it (ego shifts removed) instead "
        "of the Kalman's: a target that walks on keeps its pace, one that turned on the spot or jittered "
        "is not carried away; 0: the Kalman velocity",
        0,
        100000,
    )
    lookalike_frames: int = _f(
        12,
        "(ours, variant measured) look-alike guard: a tracked peak further than lookalike_distance from "
        "where the trail's motion before its last lookalike_frames frames puts the target (ego shifts "
        "removed) also has a window correlated there; a peak in that window, near that reference and "
        "apart from the first, of at least lookalike_ratio x the first peak is the target, and the frames "
        "since the reference are dropped from the trail (a same-looking pedestrian passing in front took "
        "the box along: demo_crossing; docs/tracking_core.md, tenth pass); pipeline kcf only; 0: off. The "
        "trail is coast_velocity_window long",
        0,
        1000,
    )
    lookalike_distance: float = _f(
        0.5,
        "(ours, variant measured) look-alike guard: the distance from the motion reference, in box widths "
        "and heights (the larger), beyond which a tracked peak is checked; the second peak must lie within "
        "half of it from the reference and at least half of it from the first peak",
        0.05,
        5.0,
    )
    lookalike_ratio: float = _f(
        0.8,
        "(ours, variant measured) look-alike guard: the peak at the motion reference wins at this ratio "
        "of the peak that left it (the motion is the tie-break between two targets that look alike)",
        0.1,
        2.0,
    )
    rejected_update: str = _f(
        "memory",
        "(ours, variant measured) Kalman update of a non-failed frame that is not accepted as `tracking` "
        "(a weak peak after an occlusion, or the long-term memory's veto) once re-detection has lasted "
        "rejected_update_after frames: 'normal' as a confident frame (the centre set to the peak), 'held' "
        "as a re-detection at the prediction (robust update, motion held), 'coast' no measurement, "
        "'memory' 'held' unless the memory finds the target in the box (then 'normal')",
        choices=("normal", "held", "coast", "memory"),
    )
    rejected_update_after: int = _f(
        25,
        "(ours, variant measured) frames of re-detection before rejected_update applies; until then a "
        "rejected frame steers the state like a confident one (a short loss: fast motion, a turn); a long "
        "occlusion must not drag the prediction onto the occluder or the background",
        0,
        100000,
    )
    rejected_size: str = _f(
        "recent",
        "(ours, variant measured) size of a non-failed frame that is not accepted as `tracking`: "
        "'measured' the winning scale, as a tracked frame; 'held' the prediction's size, as re-detection "
        "does; 'recent' the winning scale kept within the sizes the box had in the tracked frames of the "
        "last coast_velocity_window frames (and the prediction's): a turned or partly hidden target's box "
        "can grow back to a size it had (OTB girl), an occluder crossing in front cannot grow it beyond "
        "(synthetic t9: the box grew 1.16x on a pedestrian crossing in front and followed him)",
        choices=("measured", "held", "recent"),
    )
    memory_ratio: float = _f(
        0.5,
        "(ours, variant measured; LCT-style memory, Ma et al. CVPR 2015) a frame is `tracking` only when "
        "the long-term memory filter's peak on the box reaches this ratio of its mean over the verified "
        "frames; a "
        "rejected frame is `occluded` and teaches neither filter; 0: off (the papers)",
        0.0,
        2.0,
    )
    unconfident_rate: float = _f(
        0.2,
        "(ours, variant measured) once the update gate has refused unconfident_after tracked frames since it "
        "last passed one, a refused `tracking` frame still teaches the filter at this fraction of its "
        "learning rate: the model follows a lasting appearance change (stage lighting, a turn) that keeps "
        "every peak under the bar the first frames set (LMCF's means never come down); 0: frozen until a "
        "frame passes the gate (the papers)",
        0.0,
        1.0,
    )
    unconfident_after: int = _f(
        10,
        "(ours, variant measured) tracked frames the update gate must refuse (since it last passed one) "
        "before unconfident_rate applies: from the first refused frame, the tracked frames of a partial "
        "occlusion taught the filter the occluder (synthetic x_low_contrast_interlaced lost)",
        0,
        100000,
    )
    memory_rate: float = _f(
        0.01, "(ours) learning rate of the memory on frames whose memory peak is above its mean", 0.0, 1.0
    )
    max_occluded_frames: int = _f(
        250, "(ours) frames in re-detection before the state becomes lost", 1, 100000
    )
    presmooth: float = _f(
        0.02,
        "(ours, variant measured) Gaussian blur of the conditioned frame before any window is sampled, "
        "sigma = this x sqrt(w h) of the start box (0.02: 0.8-1.3 px for 25x72-40x100 px targets): windows "
        "sampled at sub-pixel positions are smoothed unequally by the bilinear interpolation, so two "
        "start boxes a pixel apart learn differently smoothed templates. With rejected_size 'recent', "
        "0.02 lifts VOT-TIR horse and PTB-TIR airplane past CSRT and the real OPE by 0.02, but OTB "
        "skating1 falls to another skater from 2 of its 12 SRE starts (docs/tracking_core.md, thirteenth "
        "pass); 0: off (the papers)",
        0.0,
        0.2,
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
        """Raise ParameterError naming the first parameter of the wrong type or out of range."""
        validate_params(self)

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.n_scales not in (1, 3, 5):
            raise ParameterError(f"parameter n_scales = {self.n_scales} must be 1, 3 or 5")
        if self.stretch_low_percentile >= self.stretch_high_percentile:
            raise ParameterError("parameter stretch_low_percentile must be below stretch_high_percentile")

    def filter_params(self) -> KCFParams | DCFCAParams | BACFParams:
        """The Params of the selected pipeline's base filter (`kcf`, `dcf_ca`, ...)."""
        return getattr(self, self.pipeline)

    def scale_factors(self) -> tuple[float, ...]:
        """Relative sizes searched in normal mode, e.g. (0.90, 0.95, 1, 1.05, 1.10)."""
        half = self.n_scales // 2
        return tuple(1.0 + self.scale_step * i for i in range(-half, half + 1))
