# SPDX-License-Identifier: Apache-2.0
"""`python -m swir_tracker_ros.harness` runs the `harness` command line."""

from __future__ import annotations

import sys

from swir_tracker_ros.harness.cli import main

sys.exit(main())
