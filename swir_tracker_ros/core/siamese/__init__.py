# SPDX-License-Identifier: Apache-2.0
"""Siamese network tracking (NanoTrack v2/v3 weights through cv2.dnn): params, weights, maths, tracker.

SiamFC (Bertinetto et al. 2016), SiamRPN++ (Li et al. 2019), SiamBAN (Chen et al. 2020), NanoTrack
(HonglinChu/SiamTrackers). docs/siamese.md.
"""
