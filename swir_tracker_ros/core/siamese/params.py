# SPDX-License-Identifier: Apache-2.0
"""Parameters of the Siamese tracker: the network (NanoTrack v2 / v3, LightTrack-M), its authors' constants.

Geometry of SiamFC (Bertinetto et al., ECCV-W 2016, Sec. 2.4): exemplar z of 127 px and search region x of
255 px, cut with context margin p = (w + h) / 2 around the target (context amount 0.5) and mean-colour
padding. Penalties of SiamRPN / SiamRPN++ (Li et al., CVPR 2018 eq. 13-14; CVPR 2019): scale and ratio
change penalty with k, cosine window with its influence, size learning rate. Head of SiamBAN (Chen et al.,
CVPR 2020): one score and four side distances per point of a stride-16 grid. The constants of each NanoTrack
version are those of the authors' configv2.yaml / configv3.yaml (HonglinChu/SiamTrackers, NanoTrack).
LightTrack-Mobile (Yan et al., CVPR 2021): the authors' VOT2019 constants and their procedure (sigmoid score,
128 px exemplar, 256 px search crop or 288 px for a target under 0.4 % of the frame, the size blended twice).
The size of the score map (16 for v2, 15 for v3, 16 / 18 for LightTrack) is read from the model's output.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.conditioning import ConditioningConfig
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import nested, param

PRECISIONS = ("float32", "int8")
"""The heads' arithmetic: the published float32 files, or int8 heads made from them (docs/siamese.md "Faster
networks"; the backbone stays float32: its int8 form measured slower and far from float's)."""
INT8_SUFFIX = "_int8.onnx"  # a made int8 head: the float head's name with this ending


@dataclass(frozen=True)
class VersionConstants:
    """What differs between the networks: the family (its input and its authors' procedure), the ONNX files
    and the tracking constants (NanoTrack: TRACK of the authors' configvN.yaml; LightTrack-M: the authors'
    experiments/test/VOT/LightTrack.yaml and lib/tracker/lighttrack.py)."""

    family: str  # "nanotrack" (float CHW input, softmax score) or "lighttrack" (uint8 HWC, sigmoid score)
    backbone: str  # pinned path under the model directory (core/siamese/weights.py)
    head: str  # the head of the `instance_size` crop
    window_influence: float  # TRACK.WINDOW_INFLUENCE / window_influence
    penalty_k: float  # TRACK.PENALTY_K / penalty_k
    size_lr: float  # TRACK.LR / lr
    exemplar_size: int  # exemplar crop side (px)
    instance_size: int  # search crop side (px)
    big_head: str = ""  # LightTrack: the head of the `big_instance_size` crop ("" : none)
    big_instance_size: int = 0  # LightTrack: big_sz, the search crop of a small target
    small_target: float = 0.0  # LightTrack: target share of the frame below which the big crop is used

    def instance_for(self, target_area: float, frame_area: float) -> int:
        """The search crop side for a target of `target_area` px^2 in a frame of `frame_area` px^2 (LightTrack
        init: big_sz when the target covers less than 0.4 % of the frame, else small_sz)."""
        if self.big_instance_size and target_area < self.small_target * frame_area:
            return self.big_instance_size
        return self.instance_size

    @property
    def files(self) -> tuple[str, ...]:
        """Every pinned file the version needs (float32)."""
        return tuple(f for f in (self.backbone, self.head, self.big_head) if f)

    def files_for(self, precision: str) -> tuple[str, ...]:
        """The pinned files of `precision` (PRECISIONS): the float backbone always; "int8": the int8 heads
        made from the float ones (core/siamese/int8.py, harness/quantise.py)."""
        if precision not in PRECISIONS:
            raise ParameterError(f"precision {precision!r}; choose from {', '.join(PRECISIONS)}")
        if precision == "float32":
            return self.files
        return (self.backbone, *(h.replace(".onnx", INT8_SUFFIX) for h in (self.head, self.big_head) if h))


VERSIONS: dict[str, VersionConstants] = {
    "v2": VersionConstants("nanotrack", "v2/nanotrack_backbone_sim.onnx", "v2/nanotrack_head_sim.onnx",
                           0.490, 0.150, 0.385, 127, 255),
    "v3": VersionConstants("nanotrack", "v3/nanotrack_backbone.onnx", "v3/nanotrack_head.onnx",
                           0.455, 0.138, 0.348, 127, 255),
    # LightTrack-Mobile (Yan et al., CVPR 2021), VOT2019 constants; exemplar 128 (the authors' --even 1, the
    # size the network is built with), search 256, or 288 below 0.4 % of the frame
    "lighttrack": VersionConstants("lighttrack", "lighttrack/lighttrack_backbone.onnx",
                                   "lighttrack/lighttrack_head_16.onnx", 0.225, 0.007, 0.616, 128, 256,
                                   "lighttrack/lighttrack_head_18.onnx", 288, 0.004),
}


@dataclass
class SiameseParams(FilterParams):
    """Parameters of `SiameseTracker`. The three tracking constants left at None take the version's value
    (`VERSIONS`); set them to override it."""

    version: str = param("v2", "network: NanoTrack v2 / v3 or LightTrack-Mobile (weights, constants, "
                               "procedure)", choices=tuple(VERSIONS))
    model_dir: str = param("", "directory holding v2/, v3/ and lighttrack/; empty: $SWIR_TRACKER_MODELS, "
                               "then the installed share directory (core/siamese/locator.py)")
    threads: int = param(1, "onnxruntime intra-op threads per network (1: measured fastest per core on a "
                            "loaded 2-core machine, docs/siamese.md)", 1, 64)
    precision: str = param("float32", "the head's arithmetic: float32 (the published heads) or int8 (heads "
                                      "quantised by `make models` from them, static QDQ calibrated on named "
                                      "development frames; the search 6-16 % shorter, maps within int8 "
                                      "rounding; docs/siamese.md \"Faster networks\"); int8 is refused while "
                                      "its files are missing", choices=PRECISIONS)
    exemplar_size: int | None = param(None, "exemplar crop side (px), SiamFC; None: the version's", 31, 511)
    instance_size: int | None = param(None, "search crop side (px), SiamFC; None: the version's (LightTrack: "
                                            "its small_sz, big_sz for a small target)", 63, 1023)
    context_amount: float = param(0.5, "context margin as a share of (w + h), SiamFC", 0.0, 2.0)
    stride: int = param(16, "score-map stride in search-crop pixels (POINT.STRIDE)", 1, 64)
    window_influence: float | None = param(None, "cosine window weight; None: the version's", 0.0, 1.0)
    penalty_k: float | None = param(None, "scale/ratio change penalty k; None: the version's", 0.0, 10.0)
    size_lr: float | None = param(None, "size learning rate; None: the version's", 0.0, 1.0)
    subpixel_crops: bool = param(
        True, "crops centred exactly on the float centre at the exact scale (one affine warp), the box "
              "decoded from that centre; False: the authors' whole-pixel windows of rounded side, decoded "
              "from the state (their trajectories exactly; a 0.5-1.5 px crop offset)")
    size_gain_power: float = param(
        0.0, "(ours, issue 52) exponent p of the size learning rate's factor min(1, g / size_gain_ref)^p, "
             "g the regression gain measured on each template's frame (maps.regression_gain: that frame "
             "searched at the template box times 1/size_test and size_test; 1 measures the size, 0 echoes "
             "the searched size); 0: off, no test, the authors' rate (docs/siamese.md \"Size from a "
             "low-gain regression\")", 0.0, 8.0)
    size_gain_ref: float = param(
        0.5, "gain from which the authors' size rate applies unchanged (size_gain_power): about the median "
             "gain of the visible development set's targets (0.47 for v3)", 0.01, 1.0)
    size_test: float = param(
        1.4142, "size factor of that test: the template's frame is searched at 1/size_test and size_test "
                "times the template box (two searches per template)", 1.05, 4.0)
    min_size: float = param(10.0, "smallest box side (px) after clipping (authors' _bbox_clip)", 1.0, 1e4)
    conditioning: ConditioningConfig = nested(
        ConditioningConfig, "how non-8-bit frames become the 8-bit gray image fed to the network")

    @property
    def constants(self) -> VersionConstants:
        """The version's constants with this instance's overrides applied."""
        c = VERSIONS[self.version]
        wi = self.window_influence
        return dataclasses.replace(
            c, window_influence=c.window_influence if wi is None else wi,
            penalty_k=c.penalty_k if self.penalty_k is None else self.penalty_k,
            size_lr=c.size_lr if self.size_lr is None else self.size_lr,
            exemplar_size=c.exemplar_size if self.exemplar_size is None else self.exemplar_size,
            instance_size=c.instance_size if self.instance_size is None else self.instance_size,
            big_instance_size=c.big_instance_size if self.instance_size is None else 0)

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        c = self.constants
        if c.instance_size <= c.exemplar_size:
            raise ParameterError("parameter instance_size must exceed exemplar_size")
        if self.conditioning.downscale != 1.0:
            raise ParameterError("parameter conditioning.downscale must be 1 for the Siamese tracker (its "
                                 "crops are resampled to the network's size already)")
