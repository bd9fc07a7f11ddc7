# SPDX-License-Identifier: Apache-2.0
"""ROS message <-> numpy/dataclass conversions: the only package that knows message layouts."""
