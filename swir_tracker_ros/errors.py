# SPDX-License-Identifier: Apache-2.0
"""One exception type per layer, each raised with a sentence saying what was wrong."""

from __future__ import annotations


class SwirTrackerError(Exception):
    """Base of every error this package raises on purpose."""


class TrackerError(SwirTrackerError):
    """The tracking core was given something it cannot track (bad box, bad frame, bad parameter)."""


class ModelError(TrackerError):
    """A model file a tracker needs (the Siamese network's weights) is missing or not the pinned one."""


class KalmanError(SwirTrackerError):
    """The Kalman filter family was given inconsistent shapes, non-finite values or bad parameters."""


class PelcoError(SwirTrackerError):
    """A Pelco-D frame or controller parameter is invalid."""


class HarnessError(SwirTrackerError):
    """The bag harness could not read, write or score a recording."""


class ParameterError(SwirTrackerError):
    """A node or core parameter is out of range or of the wrong type."""


class AcquisitionError(SwirTrackerError):
    """Detection, association or the appearance models failed on their input."""


class SceneError(SwirTrackerError):
    """The synthetic scene (world, scenarios, sprites, the demo scene) was asked for something it lacks."""


class DemoError(SwirTrackerError):
    """The closed-loop demo could not start, run or stop one of its processes."""
