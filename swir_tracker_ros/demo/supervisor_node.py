# SPDX-License-Identifier: Apache-2.0
"""Demo supervisor: records the closed-loop graph, initialises the track from ground truth, runs the scene."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from std_srvs.srv import Trigger

from msg_adapters.backend import RCLPY
from msg_adapters.camera_info import intrinsics_from_camera_info
from msg_adapters.diagnostics import statuses
from msg_adapters.errors import MessageError
from msg_adapters.geometry import box_from_polygon, box_from_roi, box_to_roi, pan_tilt_error_from_msg
from msg_adapters.ground_truth import ground_truth_state_values, scene_start_time
from msg_adapters.image import image_to_numpy
from msg_adapters.joint_state import joint_state_to_pan_tilt
from msg_adapters.qos import profile
from msg_adapters.rate import target_rate_from_msg
from msg_adapters.stamps import msg_seconds, serialized_seconds
from msg_adapters.track_state import track_state_from_msg
from swir_tracker_ros import topics
from swir_tracker_ros.demo.recording import RECORDED_TOPICS, BagRecorder, RunRecords
from swir_tracker_ros.demo.video import VideoSink, caption
from swir_tracker_ros.nodes.graph import reported_publishers

# Before the track is initialised every process must have discovered the publishers of its inputs (as it
# reports on /diagnostics): the supervisor's own view of the graph says nothing about whether, say, the
# bridge has found the tracker's error stream yet, and DDS discovery between two processes can lag the
# others by seconds (the head then stood still for the first 2.4 s of a run).
# The demo's nodes run in the root namespace under their default names (node_status_name).
POSITIONER_STATUS, TRACKER_STATUS = "/positioner_bridge: positioner", "/tracker: tracker_node"
WIRING = (
    (POSITIONER_STATUS, topics.PAN_TILT_ERROR),
    (POSITIONER_STATUS, topics.TRACK_STATE),
    (TRACKER_STATUS, topics.IMAGE),
    (TRACKER_STATUS, topics.JOINT_STATES),
    ("swir_tracker/scene_camera", topics.JOINT_STATES),
)


def _box(box) -> list[float] | None:
    return None if box is None else [box.x, box.y, box.w, box.h]


def init_answered(first_init_stamp: float, state: str, state_stamp: float) -> bool:
    """The tracker has taken /track/init: it reports an active state for a frame at or after the frame of
    the FIRST init sent (resends carry the same target on later frames).

    Comparing with the latest resend instead made the supervisor chase the tracker's replies, which are
    stamped a few frames back, for seconds on a loaded machine, while the head, already following the
    track, turned towards the paused target and past it (2.3 deg in one run).
    """
    return state in ("tracking", "occluded") and state_stamp >= first_init_stamp


class DemoSupervisor(Node):
    """Phases: wait for the graph, initialise the track, start the scene, record for `duration` seconds."""

    def __init__(self, args: argparse.Namespace) -> None:
        super().__init__("demo_supervisor")
        self.args = args
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        self.out = out
        self.rec = RunRecords(label=args.label, ego_motion_compensation=args.ego, duration_s=args.duration)
        self.bag = BagRecorder(out / "bag", storage=args.storage) if args.bag else None
        self.rec.bag = str(out / "bag") if args.bag else ""
        self.video = VideoSink(out / "debug", fps=args.fps) if args.video else None
        self.snapshot_times = [float(s) for s in args.snapshots]
        self.phase = "wait_graph"
        self.phase_since = time.time()
        self.done = False
        self.exit_code = 0
        self.latest_gt = None
        self.latest_gt_stamp = -1.0
        self.latest_state = ""
        self.latest_state_stamp = -1.0
        self.joints_seen = False
        self.reports: dict[str, dict[str, str]] = {}  # /diagnostics status name -> its latest values
        self.last_init_pub = 0.0
        self.start_future = None
        self.scene_t = 0.0
        self.scene_times: dict[float, float] = {}  # frame stamp -> scene time, recent frames
        self.last_debug_stamp: float | None = None
        self._skip_images = not args.bag_images
        # Every publisher in the demo graph is reliable (scene_camera's images too), so nothing is lost to the
        # fragmentation of large images over best-effort transport.
        for topic, type_name in RECORDED_TOPICS.items():
            if topic == topics.TRACK_INIT:
                continue  # recorded as published by this node
            if topic == topics.IMAGE and self._skip_images:
                # Not recorded: do not take a 0.6 MB reliable copy of every frame from the camera (its CPU
                # is the tracker's on a small machine); the frame stamps come from /camera/camera_info,
                # which the camera publishes with the same header for every image.
                continue
            qos = profile(topics.RECORD_IMAGE if type_name == topics.TYPES[topics.IMAGE] else topics.RECORD)
            self.create_subscription(RCLPY.cls(type_name), topic, self._make_cb(topic), qos, raw=True)
        if self.video is not None:
            debug = topics.TRACK_DEBUG_IMAGE
            self.create_subscription(RCLPY.cls(topics.TYPES[debug]), debug, self._on_debug,
                                     profile(topics.RECORD_IMAGE), raw=True)
        self.init_pub = self.create_publisher(RCLPY.cls(topics.TYPES[topics.TRACK_INIT]), topics.TRACK_INIT,
                                              profile(topics.RELIABLE))
        self.start_client = self.create_client(Trigger, topics.SCENE_START)
        self.timer = self.create_timer(0.05, self._tick)

    # ---------------------------------------------------------------- recording
    def _make_cb(self, topic: str):
        msg_type = RCLPY.cls(RECORDED_TOPICS[topic])

        def cb(data: bytes) -> None:
            now = time.time()
            if self.bag is not None and not (topic == topics.IMAGE and self._skip_images):
                self.bag.write(topic, int(now * 1e9), data)
            try:
                if topic == topics.IMAGE:  # only the stamp is needed: not worth decoding the frame
                    self.rec.frames.append([serialized_seconds(data), now])
                    return
                self._on_message(topic, deserialize_message(data, msg_type), now)
            except MessageError as exc:
                self.get_logger().warning(f"{topic}: {exc}", throttle_duration_sec=5.0)

        return cb

    def _on_message(self, topic: str, msg, now: float) -> None:
        if topic == topics.GROUND_TRUTH_BOX:
            box = box_from_polygon(msg)
            stamp = msg_seconds(msg)
            self.rec.gt.append([stamp, _box(box)])
            self.latest_gt, self.latest_gt_stamp = box, stamp
        elif topic == topics.GROUND_TRUTH_STATE:
            v = ground_truth_state_values(msg)
            if v is not None:
                stamp = msg_seconds(msg)
                self.scene_t = v["scene_time"]
                self.rec.truth.append([stamp, v["scene_time"], v["in_view"], v["visible"],
                                       v["pan_error"], v["tilt_error"], v["head_pan"], v["head_tilt"]])
                self.scene_times[round(stamp, 4)] = v["scene_time"]
                if len(self.scene_times) > 500:
                    self.scene_times.pop(next(iter(self.scene_times)))
        elif topic == topics.TRACK_BOX:
            self.rec.track.append([msg_seconds(msg), now, _box(box_from_polygon(msg))])
        elif topic == topics.PAN_TILT_ERROR:
            pan, tilt, stamp = pan_tilt_error_from_msg(msg)
            self.rec.error.append([stamp, now, pan, tilt])
        elif topic == topics.TARGET_RATE:
            pan, tilt, stamp = target_rate_from_msg(msg)
            self.rec.rate.append([stamp, now, pan, tilt])
        elif topic == topics.TRACK_STATE:
            state = track_state_from_msg(msg).value
            stamp = msg_seconds(msg)
            self.rec.state.append([stamp, now, state])
            self.latest_state, self.latest_state_stamp = state, stamp
        elif topic == topics.JOINT_STATES:
            pan, tilt, stamp = joint_state_to_pan_tilt(msg)
            self.rec.joints.append([stamp, now, pan, tilt])
            self.joints_seen = True
        elif topic == topics.CAMERA_INFO and self._skip_images:
            self.rec.frames.append([msg_seconds(msg), now])
        if topic == topics.CAMERA_INFO and not self.rec.camera:
            intr = intrinsics_from_camera_info(msg)
            self.rec.camera = {"width": intr.width, "height": intr.height, "fx": intr.fx, "fy": intr.fy,
                               "cx": intr.cx, "cy": intr.cy}
        elif topic == topics.DIAGNOSTICS:
            for name, values in statuses(msg):
                self.rec.diagnostics.append({"recv": now, "name": name, "values": values})
                self.reports[name] = values

    def _on_debug(self, data: bytes) -> None:
        if self.video is None or self.phase not in ("init", "start", "run"):
            return
        try:
            msg = deserialize_message(data, RCLPY.cls(topics.TYPES[topics.TRACK_DEBUG_IMAGE]))
            frame = image_to_numpy(msg).pixels  # bgr8 (mono8 stays 2-D), row padding honoured
            stamp = msg_seconds(msg)
        except MessageError as exc:
            self.get_logger().warning(f"{topics.TRACK_DEBUG_IMAGE}: {exc}", throttle_duration_sec=5.0)
            return
        t = self.scene_times.get(round(stamp, 4), self.scene_t)
        mode = "ego-motion compensation ON" if self.args.ego else "ego-motion compensation OFF"
        frame = caption(frame, f"scene t = {t:5.2f} s   {mode}")
        # Repeat frames over the gap since the last one: the video plays in real time at any tracker rate.
        gap = 0.0 if self.last_debug_stamp is None else stamp - self.last_debug_stamp
        repeat = round(gap * self.args.fps)
        self.last_debug_stamp = stamp
        self.video.write(frame, repeat=min(max(repeat, 1), int(self.args.fps)))
        self.rec.debug_frames += 1
        if self.snapshot_times and self.phase == "run" and t >= self.snapshot_times[0]:
            import cv2

            self.snapshot_times.pop(0)
            cv2.imwrite(str(self.out / f"frame_{t:05.2f}s.png"), frame)

    # ---------------------------------------------------------------- phases
    def unwired(self) -> list[str]:
        """The `WIRING` links not reported yet, as 'status name <- topic'."""
        return [f"{name} <- {topic}" for name, topic in WIRING
                if reported_publishers(self.reports.get(name, {}), topic) < 1]

    def _set_phase(self, phase: str) -> None:
        self.get_logger().info(f"phase {self.phase} -> {phase}")
        self.phase, self.phase_since = phase, time.time()

    def _fail(self, why: str) -> None:
        self.get_logger().error(why)
        self.rec.outcome = why
        self.exit_code = 3
        self.done = True

    def _tick(self) -> None:
        now = time.time()
        waited = now - self.phase_since
        if self.phase == "wait_graph":
            missing = self.unwired()
            ready = (self.latest_gt is not None and self.joints_seen and not missing
                     and self.init_pub.get_subscription_count() > 0 and self.start_client.service_is_ready())
            if ready:
                self.get_logger().info(f"graph wired after {waited:.1f} s")
                self._set_phase("init")
            elif waited > self.args.startup_timeout:
                have_gt = self.latest_gt is not None
                self._fail(f"graph not ready after {waited:.0f} s: ground truth {have_gt}, "
                           f"joint states {self.joints_seen}, tracker listening on /track/init "
                           f"{self.init_pub.get_subscription_count() > 0}, /scene/start "
                           f"{self.start_client.service_is_ready()}, inputs without a discovered publisher "
                           f"{missing or 'none'}")
        elif self.phase == "init":
            if init_answered(self.rec.init_time, self.latest_state, self.latest_state_stamp):
                self.start_future = self.start_client.call_async(Trigger.Request())
                self._set_phase("start")
            elif waited > self.args.init_timeout:
                self._fail(f"the tracker did not report tracking within {waited:.0f} s of /track/init "
                           f"(last state {self.latest_state!r})")
            elif now - self.last_init_pub > 0.5 and self.latest_gt is not None:
                self._publish_init(now)
        elif self.phase == "start":
            if self.start_future is not None and self.start_future.done():
                try:
                    self.rec.scene_start = scene_start_time(self.start_future.result())
                except MessageError as exc:
                    self._fail(str(exc))
                    return
                self._set_phase("run")
            elif waited > 5.0:
                self._fail(f"{topics.SCENE_START} did not answer within 5 s")
        elif self.phase == "run" and now - self.rec.scene_start >= self.args.duration:
            self.rec.outcome = "completed"
            self.done = True

    def _publish_init(self, now: float) -> None:
        box = self.latest_gt
        cam = self.rec.camera
        width, height = int(cam.get("width", 1 << 16)), int(cam.get("height", 1 << 16))
        roi = box_to_roi(box, width, height)
        self.init_pub.publish(roi)
        if self.bag is not None:
            from rclpy.serialization import serialize_message

            self.bag.write(topics.TRACK_INIT, int(now * 1e9), serialize_message(roi))
        if math.isnan(self.rec.init_time):  # the first init's frame (see `init_answered`)
            self.rec.init_time = self.latest_gt_stamp
        self.last_init_pub = now
        try:
            self.rec.init_box = list(box_from_roi(roi).as_tuple())
        except MessageError as exc:  # the ground truth box lies outside the image: the tracker refuses it
            self.get_logger().warning(f"{topics.TRACK_INIT}: {exc}", throttle_duration_sec=5.0)
            return
        self.get_logger().info(f"{topics.TRACK_INIT} {self.rec.init_box} from ground truth")

    def finish(self) -> None:
        """Close the bag and the video and write records.json (also after an interrupt)."""
        if self.bag is not None:
            self.bag.close()
            self.rec.bag_counts = dict(self.bag.counts)
        if self.video is not None:
            path = self.video.close()
            self.rec.video = str(path) if path else ""
        if self.rec.outcome == "running":
            self.rec.outcome = "interrupted"
        self.rec.supervisor_cpu_s = time.process_time()
        self.rec.save(self.out / "records.json")


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="demo_supervisor", description=__doc__)
    p.add_argument("--out", required=True, help="run folder: bag/, debug.mp4, records.json, frame_*.png")
    p.add_argument("--duration", type=float, default=30.0, help="seconds of scene to record after start")
    p.add_argument("--label", default="run")
    p.add_argument("--ego", type=int, default=1, help="1 if the tracker compensates ego-motion (for labels)")
    p.add_argument("--fps", type=float, default=25.0, help="frame rate of the debug video")
    p.add_argument("--storage", default="mcap", choices=("mcap", "sqlite3"))
    p.add_argument("--bag", type=int, default=1, help="write a rosbag2 (0: no bag)")
    p.add_argument("--bag-images", type=int, default=1, help="include /camera/image_raw in the bag")
    p.add_argument("--video", type=int, default=1, help="subscribe /track/debug_image and write a video")
    p.add_argument("--snapshots", type=float, nargs="*", default=[], help="scene times of PNG stills")
    p.add_argument("--startup-timeout", type=float, default=60.0)
    p.add_argument("--init-timeout", type=float, default=10.0)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    args = parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    args.ego = bool(args.ego)
    rclpy.init(args=argv)
    node = DemoSupervisor(args)
    try:
        while rclpy.ok() and not node.done:
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        node.rec.outcome = "interrupted"
    finally:
        node.finish()
        node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return node.exit_code if node.rec.outcome != "interrupted" else 130


if __name__ == "__main__":
    sys.exit(main())
