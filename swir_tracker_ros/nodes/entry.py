# SPDX-License-Identifier: Apache-2.0
"""Console entry points of the long-running executables (setup.py): signal-safe from the first instant.

Importing a node takes seconds (rclpy, OpenCV, SciPy, ONNX); a Ctrl-C or `ros2 launch` shutdown in that
time would print a KeyboardInterrupt traceback from deep inside an import. Here SIGINT / SIGTERM end the
process quietly with exit code 0 until the node's `main()` installs its own handling (nothing has been
started yet, so there is nothing to stop); `run_node` then takes over (docs/interfaces.md).
"""

from __future__ import annotations

import importlib
import os
import signal
from collections.abc import Callable


def _quiet_exit(_signum: int, _frame: object) -> None:
    os._exit(0)


def _entry(module: str) -> Callable[[], int]:
    def main() -> int:
        signal.signal(signal.SIGINT, _quiet_exit)
        signal.signal(signal.SIGTERM, _quiet_exit)
        return int(importlib.import_module(module).main())

    main.__doc__ = f"`{module}.main()` behind a quiet start-up (see the module docstring)."
    return main


tracker = _entry("swir_tracker_ros.nodes.tracker_node")
positioner_bridge = _entry("swir_tracker_ros.nodes.positioner_node")
scene_camera = _entry("swir_tracker_ros.simulation.scene_camera_node")
acquisition = _entry("swir_tracker_ros.nodes.acquisition_node")
pelco_sim = _entry("swir_tracker_ros.simulation.pelco_sim")
