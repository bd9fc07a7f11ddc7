# SPDX-License-Identifier: Apache-2.0
"""The long-term mechanisms around a base filter, one small class each with its own Params.

The motion filter (motion.py), the coast model (coast.py), the trail (trail.py) and the look-alike guard's
motion reference (lookalike.py) serve both pipelines: the correlation filter inside the Kalman layers and the
Siamese network leading with its own state (lead.py, judged by its appearance, gone.py, and by that motion).
The others (occlusion verdict, scale search, re-detection lattice, memory, sweep, rejected frames, update
gate, fusion) are the correlation-filter pipeline's. `Tracker` (swir_tracker_ros/tracker.py) composes them
and holds only the per-frame loop; each policy keeps its own state. Which policies a tracker has, and with
which values, is a named configuration (swir_tracker_ros/configs/): the papers' pipelines leave ours out
(None) or set them to the papers' values.
"""
