# SPDX-License-Identifier: Apache-2.0
"""params/acquisition.yaml lists every AcquisitionParams field and, under `mot.`, every MotParams field."""

from __future__ import annotations

from dataclasses import fields

import yaml
from conftest import REPO

from swir_tracker_ros.acquisition.mot import MotParams
from swir_tracker_ros.acquisition.params import AcquisitionParams
from swir_tracker_ros.paramfield import validate_params


def test_yaml_covers_every_field_with_its_default() -> None:
    doc = yaml.safe_load((REPO / "params" / "acquisition.yaml").read_text())
    values = doc["/**"]["ros__parameters"]
    mot = values.pop("mot")
    for cls, given in ((AcquisitionParams, values), (MotParams, mot)):
        assert set(given) == {f.name for f in fields(cls)}, cls.__name__
        params = cls(**given)
        params.validate()
        validate_params(params)
        assert params == cls()  # the file documents the defaults


def test_node_takes_compressed_images_and_camera_info_beside_them(context) -> None:
    """Issue 39: image_transport compressed subscribes <image_topic>/compressed; camera_info follows the image
    (image_transport's sibling convention) unless named; joint names are parameters."""
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import CameraInfo, CompressedImage

    from msg_adapters.camera_info import Intrinsics, camera_info_from_intrinsics
    from swir_tracker_ros.nodes.acquisition_node import AcquisitionNode

    overrides = [Parameter("image_topic", value="/camera1/image_raw"),
                 Parameter("image_transport", value="compressed"), Parameter("pan_joint", value="head1_pan")]
    node = AcquisitionNode(context=context, parameter_overrides=overrides)
    try:
        kinds = {s.topic_name: s.msg_type for s in node.subscriptions}
        assert kinds["/camera1/image_raw/compressed"] is CompressedImage
        assert kinds["/camera1/camera_info"] is CameraInfo
        assert "/camera1/image_raw" not in kinds
        node._on_camera_info(camera_info_from_intrinsics(Intrinsics(900.0, 900.0, 320.0, 256.0, 640, 512)))
        node.pose, node.prev_pose = (0.01, 0.0), (0.0, 0.0)
        dx, _ = node._shift(640, 512)  # the CameraInfo's focal length, not fov_h_deg's
        assert abs(dx - 900.0 * 0.010000333) < 1e-3
    finally:
        node.destroy_node()


def test_the_learned_detector_file_sets_known_parameters_to_valid_values() -> None:
    """params/acquisition_learned.yaml: only fields of AcquisitionParams / MotParams, valid together, the
    learned detector."""
    doc = yaml.safe_load((REPO / "params" / "acquisition_learned.yaml").read_text())
    values = doc["/**"]["ros__parameters"]
    mot = values.pop("mot")
    acq = AcquisitionParams(**values)
    assert acq.detector == "yolox"
    validate_params(acq)
    validate_params(MotParams(**mot))
