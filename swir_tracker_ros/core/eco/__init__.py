# SPDX-License-Identifier: Apache-2.0
"""ECO base filter (Danelljan et al., CVPR 2017; C-COT, ECCV 2016): docs/eco.md."""

from swir_tracker_ros.core.eco.filter import ECODetection, ECOFilter
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.core.eco.tracker import ECOTracker

__all__ = ["ECODetection", "ECOFilter", "ECOParams", "ECOTracker"]
