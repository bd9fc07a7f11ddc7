# SPDX-License-Identifier: Apache-2.0
"""The one `main()` life cycle every node shares: init, build, spin, clean shutdown on SIGINT/SIGTERM."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from swir_tracker_ros.errors import ParameterError

N = TypeVar("N", bound=Node)


def run_node(
    name: str,
    factory: Callable[[], N],
    argv: list[str] | None = None,
    *,
    startup_errors: tuple[type[Exception], ...] = (ParameterError,),
    before_destroy: Callable[[N], None] | None = None,
) -> int:
    """Run one node until SIGINT/SIGTERM and return the process exit code.

    0 after a signal; 2 when building the node raises one of `startup_errors` (a bad parameter, a missing
    model), logged as one line. A signal that arrives while the node is still being built also gives 0.
    Any other exception propagates, after `before_destroy(node)` (e.g. the positioner's final stop),
    `destroy_node()` and `rclpy.try_shutdown()` have run.
    """
    rclpy.init(args=list(sys.argv if argv is None else argv))
    try:
        node = factory()
    except startup_errors as exc:
        rclpy.logging.get_logger(name).error(f"cannot start: {exc}")
        rclpy.try_shutdown()
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        rclpy.try_shutdown()
        return 0
    except Exception:
        if rclpy.ok():
            rclpy.try_shutdown()
            raise
        return 0  # the signal's shutdown invalidated the context while the node was being built
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if node.context.ok():
            raise  # a real failure; after a signal, spin may fail on the invalidated context instead
    finally:
        if before_destroy is not None:
            before_destroy(node)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
