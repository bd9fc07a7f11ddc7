# SPDX-License-Identifier: Apache-2.0
"""Thin rclpy nodes: they declare parameters, wire topics and call into the ROS-free core."""
