# SPDX-License-Identifier: Apache-2.0
"""Siamese network tracking (NanoTrack v2/v3 and LightTrack-M through onnxruntime): params, weights,
maths, tracker.

SiamFC (Bertinetto et al. 2016), SiamRPN++ (Li et al. 2019), SiamBAN (Chen et al. 2020), NanoTrack
(HonglinChu/SiamTrackers). docs/siamese.md.
"""
