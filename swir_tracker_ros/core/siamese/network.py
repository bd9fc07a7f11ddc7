# SPDX-License-Identifier: Apache-2.0
"""The NanoTrack network through OpenCV's DNN module: a shared backbone and the depthwise-correlation head.

NanoTrack (HonglinChu/SiamTrackers) follows SiamRPN++'s depthwise cross-correlation (Li et al., CVPR 2019,
Sec. 3.4) and SiamBAN's anchor-free head (Chen et al., CVPR 2020): the backbone (MobileNetV3) maps the
127 px exemplar to 8x8 and the 255 px search crop to 16x16 feature maps; the head correlates them and gives
`output1` (2 x S x S class logits) and `output2` (4 x S x S side distances). The exemplar features are
computed once per template (`set_exemplar`), the search features on every search. No PyTorch at run time.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.params import VersionConstants
from swir_tracker_ros.errors import ModelError, TrackerError


class NanoNet:
    """The backbone and head of one NanoTrack version, loaded from their verified ONNX files."""

    def __init__(self, constants: VersionConstants, model_dir: str | Path | None = None) -> None:
        self.backbone_path = locate(constants.backbone, model_dir)
        self.head_path = locate(constants.head, model_dir)
        try:
            self._backbone = cv2.dnn.readNetFromONNX(str(self.backbone_path))
            self._head = cv2.dnn.readNetFromONNX(str(self.head_path))
        except cv2.error as exc:
            raise ModelError(f"model file {self.backbone_path} or {self.head_path} cannot be loaded by "
                             f"cv2.dnn ({str(exc).strip().splitlines()[-1]})") from None
        self._z: np.ndarray | None = None

    def features(self, crop_blob: np.ndarray) -> np.ndarray:
        """Backbone features of a 1x3xSxS crop."""
        self._backbone.setInput(crop_blob)
        return self._backbone.forward().copy()

    def set_exemplar(self, z_blob: np.ndarray) -> None:
        """Compute and keep the exemplar's features (the template)."""
        self._z = self.features(z_blob)

    @property
    def has_exemplar(self) -> bool:
        return self._z is not None

    def search(self, x_blob: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(cls 2xSxS, loc 4xSxS) of a search crop against the kept exemplar."""
        if self._z is None:
            raise TrackerError("the Siamese network has no exemplar yet: call init() first")
        x = self.features(x_blob)
        self._head.setInput(self._z, "input1")
        self._head.setInput(x, "input2")
        cls, loc = self._head.forward(["output1", "output2"])
        return cls[0], loc[0]
