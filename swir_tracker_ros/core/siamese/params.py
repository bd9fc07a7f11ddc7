# SPDX-License-Identifier: Apache-2.0
"""Parameters of the Siamese tracker: the model version and the authors' per-version tracking constants.

Geometry of SiamFC (Bertinetto et al., ECCV-W 2016, Sec. 2.4): exemplar z of 127 px and search region x of
255 px, cut with context margin p = (w + h) / 2 around the target (context amount 0.5) and mean-colour
padding. Penalties of SiamRPN / SiamRPN++ (Li et al., CVPR 2018 eq. 13-14; CVPR 2019): scale and ratio
change penalty with k, cosine window with its influence, size learning rate. Head of SiamBAN (Chen et al.,
CVPR 2020): one score and four side distances per point of a stride-16 grid. The constants of each NanoTrack
version are those of the authors' configv2.yaml / configv3.yaml (HonglinChu/SiamTrackers, NanoTrack).
The size of the score map (16 for v2, 15 for v3) is read from the model's output, never assumed.
"""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.conditioning import ConditioningConfig
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import nested, param


@dataclass(frozen=True)
class VersionConstants:
    """What differs between NanoTrack versions: the ONNX pair and the tracking constants (TRACK section of
    the authors' configvN.yaml)."""

    backbone: str  # pinned path under the model directory (core/siamese/weights.py)
    head: str
    window_influence: float  # TRACK.WINDOW_INFLUENCE
    penalty_k: float  # TRACK.PENALTY_K
    size_lr: float  # TRACK.LR


VERSIONS: dict[str, VersionConstants] = {
    "v2": VersionConstants("v2/nanotrack_backbone_sim.onnx", "v2/nanotrack_head_sim.onnx",
                           0.490, 0.150, 0.385),
    "v3": VersionConstants("v3/nanotrack_backbone.onnx", "v3/nanotrack_head.onnx", 0.455, 0.138, 0.348),
}


@dataclass
class SiameseParams(FilterParams):
    """Parameters of `SiameseTracker`. The three tracking constants left at None take the version's value
    (`VERSIONS`); set them to override it."""

    version: str = param("v2", "NanoTrack model version (weights and constants)", choices=tuple(VERSIONS))
    model_dir: str = param("", "directory holding v2/ and v3/; empty: $SWIR_TRACKER_MODELS, then the "
                               "installed share directory (core/siamese/locator.py)")
    exemplar_size: int = param(127, "exemplar crop side (px), SiamFC", 31, 511)
    instance_size: int = param(255, "search crop side (px), SiamFC", 63, 1023)
    context_amount: float = param(0.5, "context margin as a share of (w + h), SiamFC", 0.0, 2.0)
    stride: int = param(16, "score-map stride in search-crop pixels (POINT.STRIDE)", 1, 64)
    window_influence: float | None = param(None, "cosine window weight; None: the version's", 0.0, 1.0)
    penalty_k: float | None = param(None, "scale/ratio change penalty k; None: the version's", 0.0, 10.0)
    size_lr: float | None = param(None, "size learning rate; None: the version's", 0.0, 1.0)
    subpixel_crops: bool = param(
        True, "crops centred exactly on the float centre at the exact scale (one affine warp), the box "
              "decoded from that centre; False: the authors' whole-pixel windows of rounded side, decoded "
              "from the state (their trajectories exactly; a 0.5-1.5 px crop offset)")
    min_size: float = param(10.0, "smallest box side (px) after clipping (authors' _bbox_clip)", 1.0, 1e4)
    conditioning: ConditioningConfig = nested(
        ConditioningConfig, "how non-8-bit frames become the 8-bit gray image fed to the network")

    @property
    def constants(self) -> VersionConstants:
        """The version's constants with this instance's overrides applied."""
        c = VERSIONS[self.version]
        return VersionConstants(
            c.backbone, c.head,
            c.window_influence if self.window_influence is None else self.window_influence,
            c.penalty_k if self.penalty_k is None else self.penalty_k,
            c.size_lr if self.size_lr is None else self.size_lr)

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.instance_size <= self.exemplar_size:
            raise ParameterError("parameter instance_size must exceed exemplar_size")
        if self.conditioning.downscale != 1.0:
            raise ParameterError("parameter conditioning.downscale must be 1 for the Siamese tracker (its "
                                 "crops are resampled to the network's size already)")
