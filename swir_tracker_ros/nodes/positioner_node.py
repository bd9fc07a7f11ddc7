# SPDX-License-Identifier: Apache-2.0
"""`positioner_bridge`: /track/pan_tilt_error -> Pelco-D on a serial line, /positioner/joint_states back."""

from __future__ import annotations

import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from msg_adapters import diagnostics
from msg_adapters.errors import MessageError
from msg_adapters.geometry import pan_tilt_error_from_msg
from msg_adapters.joint_state import PanTiltSample, pan_tilt_to_joint_state
from msg_adapters.qos import profile
from msg_adapters.stamps import header
from msg_adapters.track_state import track_state_from_msg
from swir_tracker_ros import topics
from swir_tracker_ros.errors import ParameterError, PelcoError
from swir_tracker_ros.nodes.graph import input_publishers
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile, usage_lines
from swir_tracker_ros.nodes.ros_params import bind_parameters
from swir_tracker_ros.nodes.runner import run_node
from swir_tracker_ros.pelco.bridge import PositionerBridge
from swir_tracker_ros.pelco.params import PositionerParams

ERROR_TOPIC, STATE_TOPIC = topics.PAN_TILT_ERROR, topics.TRACK_STATE
STATUS_NAME = "swir_tracker/positioner"


class PositionerNode(Node):
    """Thin wrapper: parameters, topics and timers around `PositionerBridge` (which owns the port)."""

    def __init__(self) -> None:
        super().__init__("positioner_bridge")
        self.params = bind_parameters(self, PositionerParams, on_change=self._on_params)
        self.bridge = PositionerBridge(self.params, log=self._log, clock=time.monotonic)
        # Best effort accepts both reliable and best-effort publishers; only the latest error matters.
        self.create_subscription(Vector3Stamped, ERROR_TOPIC, self._on_error, profile(topics.LATEST))
        reliable = profile(topics.RELIABLE)
        self.create_subscription(DiagnosticArray, STATE_TOPIC, self._on_state, reliable)
        self.joint_pub = self.create_publisher(JointState, topics.JOINT_STATES, reliable)
        self.diag_pub = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, reliable)
        p = self.params
        tick = min(200.0, max(50.0, 2.0 * p.control_rate, 4.0 * p.feedback_rate))
        self.create_timer(1.0 / tick, self._tick)
        self.create_timer(1.0 / p.joint_state_rate, self._publish_joint_state)
        self.create_timer(1.0, self._publish_diagnostics)
        self._bad_messages = 0
        self.get_logger().info(f"Pelco-D head at address {p.address} on {p.port} ({p.baud} baud), "
                               f"watchdog {p.watchdog_timeout} s")

    def _log(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a severity change at the same call site
        if level == "warn":
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

    def _on_params(self, params: PositionerParams) -> None:
        self.params = params
        self.bridge.set_params(params)

    def _on_error(self, msg: Vector3Stamped) -> None:
        try:
            pan, tilt, _stamp = pan_tilt_error_from_msg(msg)
        except MessageError as exc:
            self._bad_messages += 1
            self.get_logger().warning(f"ignoring {ERROR_TOPIC}: {exc}", throttle_duration_sec=5.0)
            return
        self.bridge.on_error(pan, tilt)

    def _on_state(self, msg: DiagnosticArray) -> None:
        try:
            self.bridge.on_state(track_state_from_msg(msg))
        except MessageError as exc:
            self._bad_messages += 1
            self.get_logger().warning(f"ignoring {STATE_TOPIC}: {exc}", throttle_duration_sec=5.0)

    def _tick(self) -> None:
        self.bridge.step()

    def _now_seconds(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _publish_joint_state(self) -> None:
        mono = time.monotonic()
        pose = self.bridge.pose(mono)
        if pose is None:
            return
        stamp = max(self._now_seconds() - (mono - pose.time), 0.0)
        sample = PanTiltSample(pose.pan, pose.tilt, pose.pan_velocity, pose.tilt_velocity, stamp)
        self.joint_pub.publish(pan_tilt_to_joint_state(sample, self.params.frame_id))

    def _publish_diagnostics(self) -> None:
        b = self.bridge
        values = dict(b.stats(), bad_messages=self._bad_messages,
                      feedback="true" if b.pose() is not None else "false",
                      **input_publishers(self, (ERROR_TOPIC, STATE_TOPIC)))
        if not b.link.connected:
            level, text = diagnostics.ERROR, f"port {self.params.port} unavailable, retrying"
        elif b.pose() is None and self.params.feedback_rate > 0:
            level, text = diagnostics.WARN, "no position feedback"
        else:
            level, text = diagnostics.OK, b.reason
        st = diagnostics.status(STATUS_NAME, level, text, values,
                                hardware_id=f"pelco-d:{self.params.address}")
        self.diag_pub.publish(diagnostics.diagnostic_array(header(self._now_seconds()), [st]))


def _stop_head(node: PositionerNode) -> None:
    """SIGINT / SIGTERM (rclpy's handlers shut the context down) and exceptions all land here: the head
    is told to stop before the port closes."""
    sent = node.bridge.shutdown()
    print(f"positioner_bridge: stop {'written' if sent else 'NOT written (port unavailable)'} "
          "before closing the port", file=sys.stderr, flush=True)


PARAMS_FILE = ParamsFile(
    "params/positioner.yaml", "positioner_bridge", (("", PositionerParams, ""),),
    "Parameters of the positioner bridge (`positioner_bridge`; docs/positioner.md: wiring and sign "
    "conventions), every one at its default. " + GENERATED + " swir_tracker_ros/pelco/params.py, not this "
    "file. Units: rad, rad/s, s, Hz, deg/s in the speed tables.")


def usage() -> str:
    """`positioner_bridge --help`: how to start the bridge and every parameter with its default."""
    return "\n".join([
        "usage: positioner_bridge [--help]",
        "       positioner_bridge --ros-args --params-file params/positioner.yaml [-p name:=value ...]", "",
        "Drives a Pelco-D pan-tilt head from /track/pan_tilt_error; see docs/positioner.md.", "",
        "parameters:", *usage_lines(PositionerParams)])


def main(argv: list[str] | None = None) -> int:
    """Console entry point `positioner_bridge`: spin until SIGINT/SIGTERM (the head is stopped last);
    exit 2 on a bad parameter or a port URL that can never be opened."""
    return run_node("positioner_bridge", PositionerNode, argv, before_destroy=_stop_head, usage=usage,
                    startup_errors=(ParameterError, PelcoError))


if __name__ == "__main__":
    sys.exit(main())
