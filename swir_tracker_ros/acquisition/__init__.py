# SPDX-License-Identifier: Apache-2.0
"""Target acquisition: detection, multi-pedestrian association (paper 004), Siamese nets, hand-off."""
