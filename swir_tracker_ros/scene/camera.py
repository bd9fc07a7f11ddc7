# SPDX-License-Identifier: Apache-2.0
"""Pinhole camera on a pan-tilt head looking into the angular world (REP-103 signs: pan left +, tilt up +)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CameraView:
    """Where the camera looks and what it sees.

    pan, tilt: head angles in radians (pan positive to the left, tilt positive upwards, docs/interfaces.md).
    hfov_deg: horizontal field of view; square pixels, so the vertical focal length equals the horizontal.
    width, height: image size in pixels. Pixel (i, j) covers [i, i+1) x [j, j+1); the principal point is the
    image centre (width/2, height/2), so `pan_error = atan2(cx - u, fx)` of a point at column u is exactly its
    azimuth minus `pan`.
    """

    pan: float = 0.0
    tilt: float = 0.0
    hfov_deg: float = 8.0
    width: int = 576
    height: int = 504

    @property
    def fx(self) -> float:
        return (self.width / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def fy(self) -> float:
        return self.fx

    @property
    def cx(self) -> float:
        return self.width / 2.0

    @property
    def cy(self) -> float:
        return self.height / 2.0

    def shifted(self, dpan: float, dtilt: float) -> CameraView:
        return CameraView(self.pan + dpan, self.tilt + dtilt, self.hfov_deg, self.width, self.height)

    def project(self, azimuth: float, elevation: float) -> tuple[float, float]:
        """Angles (rad) -> continuous pixel (u, v): u = cx - fx tan(az - pan), v = cy - fy tan(el - tilt)."""
        return (
            self.cx - self.fx * math.tan(azimuth - self.pan),
            self.cy - self.fy * math.tan(elevation - self.tilt),
        )

    def unproject(self, u: float, v: float) -> tuple[float, float]:
        """Continuous pixel (u, v) -> (azimuth, elevation) in radians; inverse of `project`."""
        return (
            self.pan + math.atan2(self.cx - u, self.fx),
            self.tilt + math.atan2(self.cy - v, self.fy),
        )

    def pixel_angles(self) -> tuple[np.ndarray, np.ndarray]:
        """Azimuth of every pixel-centre column (width,) and elevation of every row (height,), radians."""
        u = np.arange(self.width, dtype=np.float64) + 0.5
        v = np.arange(self.height, dtype=np.float64) + 0.5
        return self.pan + np.arctan2(self.cx - u, self.fx), self.tilt + np.arctan2(self.cy - v, self.fy)

    def camera_info(self) -> dict[str, object]:
        """Plain intrinsics (K row-major, plumb-bob D of zeros) for a sensor_msgs/CameraInfo adapter."""
        return {
            "width": self.width,
            "height": self.height,
            "k": [self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0],
            "d": [0.0] * 5,
            "distortion_model": "plumb_bob",
        }
