# SPDX-License-Identifier: Apache-2.0
"""Image-sample geometry of the ECO filter: how large the sample is, on which cell grids, at which resolution.

The sample covers `search_area_scale` times the target (square of side sqrt(w h) x scale, or proportional),
and at least `min_search_side` image pixels (ours: a small target that moves a few of its sizes between
frames stays inside the sample);
its resolution is chosen so that its area lies within [min_sample_size^2, max_sample_size^2] sample pixels
(ECO-HC `min/max_image_sample_size`): a small target is resampled up, a large one down. The support (the
sample's side in sample pixels, the period T of every feature block) is a multiple of every block's cell, so
each block tiles it exactly and all blocks share one frequency axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from swir_tracker_ros.core.eco.features import BlockSpec
from swir_tracker_ros.core.eco.params import ECOParams


@dataclass(frozen=True)
class SampleGeometry:
    """scale: image pixels per sample pixel at the first frame; base (h, w): the target in sample pixels;
    support (rows, cols): the sample in sample pixels; blocks: the feature blocks."""

    scale: float
    base: tuple[float, float]
    support: tuple[int, int]
    blocks: tuple[BlockSpec, ...]

    def grid(self, b: int) -> tuple[int, int]:
        """(rows, cols) of block b's cell grid."""
        c = self.blocks[b].cell
        return self.support[0] // c, self.support[1] // c


def feature_blocks(p: ECOParams) -> tuple[BlockSpec, ...]:
    """The blocks the parameters ask for: FHOG, and intensity channels unless intensity_cell is 0."""
    blocks = [BlockSpec("hog", p.hog_cell, p.hog_dim, soft=p.hog_soft)]
    if p.intensity_cell > 0:
        blocks.append(BlockSpec("intensity", p.intensity_cell, p.intensity_dim, p.intensity_bins))
    return tuple(blocks)


def _round_support(side: float, step: int) -> int:
    """The smallest multiple of `step` not below `side` (at least 3 steps): every block tiles the sample
    exactly;
    rounding up keeps the sample at least `min_sample_size` (the reference rounds to the nearest odd multiple
    of its largest cell, 150 -> 162 px at ECO-HC's minimum; here 150 -> 156)."""
    return max(3 * step, step * math.ceil(side / step - 1e-9))


def sample_geometry(w: float, h: float, p: ECOParams) -> SampleGeometry:
    """Sample geometry for a first-frame target of w x h image pixels."""
    blocks = feature_blocks(p)
    ratio = p.search_area_scale
    if p.min_search_side > 0:  # small targets: the sample covers at least this many image pixels (ours)
        ratio = max(ratio, p.min_search_side / math.sqrt(w * h))
    area = w * h * ratio**2
    if area > p.max_sample_size**2:
        scale = math.sqrt(area / p.max_sample_size**2)
    elif area < p.min_sample_size**2:
        scale = math.sqrt(area / p.min_sample_size**2)
    else:
        scale = 1.0
    bw, bh = w / scale, h / scale
    if p.search_area_shape == "square":
        sy = sx = math.sqrt(bw * bh) * ratio
    else:
        sy, sx = bh * ratio, bw * ratio
    step = math.lcm(*(b.cell for b in blocks))
    return SampleGeometry(scale, (bh, bw), (_round_support(sy, step), _round_support(sx, step)), blocks)
