# SPDX-License-Identifier: Apache-2.0
"""Flat parameters of the acquisition node (the association's own are MotParams, bound under `mot.`)."""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros import topics
from swir_tracker_ros.acquisition.detectors import (
    Detector,
    HogParams,
    HogPeopleDetector,
    MotionDetector,
    MotionParams,
)
from swir_tracker_ros.acquisition.handoff import AutoInitParams
from swir_tracker_ros.acquisition.learned import YoloxDetector, YoloxParams, model_problem
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param as _f
from swir_tracker_ros.paramfield import validate_params

DETECTORS = ("motion", "hog", "yolox")
_M = MotionParams()  # the motion detector's defaults are written once, in MotionParams
_Y = YoloxParams()  # ... and the learned detector's in YoloxParams


@dataclass
class AcquisitionParams:
    """Topics, detector choice, hand-off behaviour and the detectors' settings."""

    image_topic: str = _f(topics.IMAGE, "input image topic, image_transport's base name", read_only=True)
    image_transport: str = _f("raw", "raw (sensor_msgs/Image on image_topic) or compressed (CompressedImage, "
                              "JPEG or PNG, on image_topic/compressed)", choices=topics.TRANSPORTS,
                              read_only=True)
    camera_info_topic: str = _f("", "CameraInfo (its focal length for the ego-motion shift; fov_h_deg "
                                "until one arrives); '' = beside the image "
                                "(<dirname(image_topic)>/camera_info)",
                                read_only=True, empty_derived=True)
    joint_states_topic: str = _f(topics.JOINT_STATES, "head joint states for ego-motion (bring-up: "
                                 "joint_states)", read_only=True)
    pan_joint: str = _f("pan", "name of the pan joint in the joint states (bring-up's pan_joint)",
                        read_only=True)
    tilt_joint: str = _f("tilt", "name of the tilt joint in the joint states (bring-up's tilt_joint)",
                         read_only=True)
    detector: str = _f("motion", "detector: motion (background subtraction), hog (OpenCV people) or yolox "
                       "(learned, YOLOX-Nano; needs `make models`)", choices=DETECTORS)
    detect_every: int = _f(1, "detect and associate on every this many frames (the others are only "
                           "counted; the head's motion over the skipped frames is accumulated); e.g. 3 for "
                           "10 Hz detection on a 30 Hz camera", 1, 100)
    fov_h_deg: float = _f(8.0, "horizontal field of view (deg) for the ego-motion shift without CameraInfo",
                          0.1, 179.0)
    ego_motion_compensation: bool = _f(True, "compensate detector and predictions for the head's motion")
    auto_handoff: bool = _f(False, "hand off a confirmed moving target by itself (tracker idle or lost)")
    candidates: int = _f(3, "tracks offered when the single-object tracker reports lost", 1, 50)
    publish_debug: bool = _f(True, "publish /acquisition/debug_image (only with subscribers)")
    motion_history: int = _f(_M.history, "frames in the temporal-median background buffer", 1, 201)
    motion_sample_every: int = _f(_M.sample_every,
                                  "a frame enters the background buffer every this many frames", 1, 100)
    motion_threshold: float = _f(_M.threshold,
                                 "foreground above this difference to the background (8-bit levels)",
                                 1.0, 255.0)
    motion_min_area: float = _f(_M.min_area, "smallest foreground region kept (px)", 0.0, 1e7)
    motion_open_size: int = _f(_M.open_size, "morphological opening kernel (px)", 1, 51)
    motion_close_size: int = _f(_M.close_size, "morphological closing kernel (px) until people are found "
                                f"(then {_M.close_rel} x their running median height)", 1, 101)
    hog_hit_threshold: float = _f(0.0, "HOG SVM hit threshold", -5.0, 5.0)
    hog_upscale: float = _f(1.0, "resize factor before HOG (people under 128 px need > 1)", 0.25, 4.0)
    yolox_score: float = _f(_Y.score, "learned detector: keep a person scoring (objectness x class) at "
                            "least this", 0.01, 1.0)
    yolox_nms_iou: float = _f(_Y.nms_iou, "learned detector: non-maximum suppression overlap (IoU)",
                              0.05, 1.0)
    yolox_threads: int = _f(_Y.threads, "learned detector: onnxruntime threads", 1, 16)
    auto_iou: float = _f(0.5, "automatic confirmation: IoU with the temporary track's prediction", 0.0, 1.0)
    auto_updates: int = _f(5, "automatic confirmation: updates needed", 1, 100)
    auto_window: int = _f(10, "automatic confirmation: frames allowed", 1, 1000)

    def validate(self) -> None:
        """Raise `ParameterError` naming the first bad field (`paramfield.validate_params`)."""
        validate_params(self)

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.auto_updates > self.auto_window:
            raise ParameterError(f"parameter auto_updates = {self.auto_updates} exceeds auto_window "
                                 f"= {self.auto_window}")

    def detector_problem(self) -> str | None:
        """Why the chosen detector cannot be built (the learned one without its pinned file), else None."""
        return model_problem() if self.detector == "yolox" else None

    def make_detector(self) -> Detector:
        """The chosen detector; AcquisitionError (one line naming `make models`) when the learned one's
        model file is missing or not the pinned one."""
        if self.detector == "yolox":
            return YoloxDetector(YoloxParams(score=self.yolox_score, nms_iou=self.yolox_nms_iou,
                                             threads=self.yolox_threads))
        if self.detector == "hog":
            hog = HogParams(hit_threshold=self.hog_hit_threshold, upscale=self.hog_upscale)
            return HogPeopleDetector(hog)
        return MotionDetector(MotionParams(history=self.motion_history, sample_every=self.motion_sample_every,
                                           threshold=self.motion_threshold,
                                           min_area=self.motion_min_area, open_size=self.motion_open_size,
                                           close_size=self.motion_close_size))

    def auto_init(self) -> AutoInitParams:
        return AutoInitParams(iou_threshold=self.auto_iou, required_updates=self.auto_updates,
                              window=self.auto_window)
