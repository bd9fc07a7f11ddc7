# SPDX-License-Identifier: Apache-2.0
"""SWIR pan-tilt single-object tracker: ROS-free algorithm core plus thin ROS 2 nodes."""

__version__ = "0.1.0"
