# SPDX-License-Identifier: Apache-2.0
"""rosbag2 regression harness: bag IO, OTB metrics, evaluation, regression gate, OpenCV comparison, replay."""
