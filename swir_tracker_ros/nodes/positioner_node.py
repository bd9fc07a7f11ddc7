# SPDX-License-Identifier: Apache-2.0
"""`positioner_bridge`: track/pan_tilt_error and the operator's commands -> Pelco-D on a serial line,
positioner/joint_states back; unmanaged by default, a lifecycle node with `--managed`."""

from __future__ import annotations

import sys

from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node

from swir_tracker_ros.errors import ParameterError, PelcoError
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile, usage_lines
from swir_tracker_ros.nodes.positioner_surface import STATUS_NAME, HeadSurface
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node, user_arguments
from swir_tracker_ros.pelco.bridge import HeadMode
from swir_tracker_ros.pelco.params import PositionerParams

NODE_NAME = "positioner_bridge"
MANAGED_FLAG = "--managed"
__all__ = ["STATUS_NAME", "ManagedPositionerNode", "PositionerNode", "main"]


class PositionerNode(Node):
    """Unmanaged: the bridge runs from construction to shutdown (the port is opened, and reopened after
    an outage, by the bridge's own retries)."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = bind_parameters(self, PositionerParams, on_change=self._on_params)
        self.surface = HeadSurface(self, self.params)
        self.bridge = self.surface.make_bridge()
        self.surface.active = True
        self.surface.publish_mode(self.bridge.mode, "start-up")
        p = self.params
        self.get_logger().info(f"Pelco-D head at address {p.address} on {p.port} ({p.baud} baud), "
                               f"mode {p.initial_mode}, watchdog {p.watchdog_timeout} s")

    def _on_params(self, params: PositionerParams) -> None:
        self.params = params
        self.surface.set_params(params)


class ManagedPositionerNode(LifecycleNode):
    """Managed (REP-2008 style life cycle): configure opens and checks the port, activate starts control
    (a stop, then `initial_mode`), deactivate stops the head and falls silent, cleanup closes the port."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME)
        self.params = bind_parameters(self, PositionerParams, on_change=self._on_params)
        self.surface = HeadSurface(self, self.params)
        self.get_logger().info(f"managed: waiting for configure (port {self.params.port})")

    def _on_params(self, params: PositionerParams) -> None:
        self.params = params
        self.surface.set_params(params)

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        p = self.params
        try:
            bridge = self.surface.make_bridge(mode=HeadMode.RELEASED)  # silent until activated
        except PelcoError as exc:
            self.get_logger().error(f"configure failed: {exc}")
            return TransitionCallbackReturn.FAILURE
        problem = bridge.open_and_check(timeout=max(4 * p.reply_timeout, 0.5))
        if problem:
            bridge.link.close()
            self.surface.bridge = None
            self.get_logger().error(f"configure failed: {problem}")
            return TransitionCallbackReturn.FAILURE
        self.get_logger().info(f"configured: {p.port} open at {p.baud} baud" +
                               (", the head answers" if p.feedback_rate > 0 else ""))
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.surface.active = True
        self.surface.bridge.set_mode(HeadMode(self.params.initial_mode), "lifecycle activate")
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.surface.bridge.set_mode(HeadMode.RELEASED, "lifecycle deactivate")  # writes the stop first
        self.surface.active = False
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._close()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        if self.surface.active:
            _stop_head(self)
        self._close()
        return TransitionCallbackReturn.SUCCESS

    def _close(self) -> None:
        if self.surface.bridge is not None:
            self.surface.bridge.link.close()
        self.surface.bridge, self.surface.active = None, False
        self.get_logger().info("port closed")


def _stop_head(node: PositionerNode | ManagedPositionerNode) -> None:
    """SIGINT / SIGTERM (rclpy's handlers shut the context down) and exceptions all land here: the head
    is told to stop before the port closes, except in released mode (another controller owns the bus, and
    a stop would cut its move short). Then the action server goes, before the node."""
    surface = node.surface
    if surface.bridge is not None and surface.active:
        outcome = surface.bridge.shutdown()
        text = {"written": "stop written", "not written": "stop NOT written (port unavailable)",
                "released": "nothing written (released: the head belongs to another controller)"}[outcome]
        surface.active = False
        print(f"positioner_bridge: {text} before closing the port", file=sys.stderr, flush=True)
    surface.destroy()


PARAMS_FILE = ParamsFile(
    "params/positioner.yaml", "/**", (("", PositionerParams, ""),),
    "Parameters of the positioner bridge (`positioner_bridge`; docs/positioner.md: wiring and sign "
    "conventions), every one at its default. " + GENERATED + " swir_tracker_ros/pelco/params.py, not this "
    "file. Units: rad, rad/s, s, Hz, deg/s in the speed tables.")


def usage() -> str:
    """`positioner_bridge --help`: how to start the bridge and every parameter with its default."""
    return "\n".join([
        "usage: positioner_bridge [--help] [--managed]",
        "       positioner_bridge [--managed] --ros-args --params-file params/positioner.yaml "
        "[-p name:=value ...]", "",
        "Drives a Pelco-D pan-tilt head from track/pan_tilt_error and the positioner/* control surface; see "
        "docs/positioner.md.",
        "--managed: a lifecycle node (configure opens and checks the port, activate starts control); "
        "without it the bridge starts at once.", "",
        "parameters:", *usage_lines(PositionerParams)])


def main(argv: list[str] | None = None) -> int:
    """Console entry point `positioner_bridge`: spin until SIGINT/SIGTERM (the head is stopped last);
    exit 2 on a bad parameter or a port URL that can never be opened."""
    args = list(sys.argv if argv is None else argv)
    factory = ManagedPositionerNode if MANAGED_FLAG in user_arguments(args) else PositionerNode
    return run_node(NODE_NAME, factory, args, before_destroy=_stop_head, usage=usage,
                    startup_errors=(ParameterError, PelcoError))


if __name__ == "__main__":
    sys.exit(main())
