# SPDX-License-Identifier: Apache-2.0
"""The long-term mechanisms around a base correlation filter, one small class each with its own Params.

`Tracker` (swir_tracker_ros/tracker.py) composes them and holds only the per-frame loop; each policy keeps
its own state. Which policies a tracker has, and with which values, is a named configuration
(swir_tracker_ros/configs/): the papers' pipelines leave ours out (None) or set them to the papers' values.
"""
