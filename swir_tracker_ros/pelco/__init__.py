# SPDX-License-Identifier: Apache-2.0
"""Pelco-D positioner: codec, controller, serial link, bridge core and a simulated head (no rclpy)."""
