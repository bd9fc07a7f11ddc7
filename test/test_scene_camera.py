# SPDX-License-Identifier: Apache-2.0
"""The demo scene and the `scene_camera` node: off-centre start, occlusions with a hidden stop, rendering
at the head's pose, the paused scene clock and the ground-truth topics."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from conftest import wait_for

from swir_tracker_ros.errors import SceneError
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_scene import (
    DEMO_DURATION_S,
    TARGET_ID,
    VARIANTS,
    SceneClock,
    build_scene,
    initial_target_box,
    scene_names,
)


@pytest.fixture(scope="module")
def demo_scene():
    return build_scene("demo", seed=7)


def target_truth(scene, t: float, view: CameraView):
    _frame, truths = scene.world.render(t, view)
    return next(tr for tr in truths if tr.id == TARGET_ID)


def test_demo_scene_starts_off_centre_and_in_view(demo_scene) -> None:
    truth = target_truth(demo_scene, 0.0, CameraView(0.0, 0.0, 8.0, 576, 504))
    assert truth.in_view and truth.visible_fraction > 0.9
    assert math.degrees(truth.azimuth) > 1.5  # left of the rest pose: the head must pan left first
    assert math.degrees(truth.elevation) < -0.5  # and tilt down
    box = initial_target_box()
    assert box[0] + box[2] / 2 < 576 / 2 - 100  # its box is far from the image centre


def test_demo_scene_hides_the_target_while_it_stops(demo_scene) -> None:
    """Full occlusion behind the wall, with a stop inside it (a manoeuvre while hidden)."""
    target = demo_scene.world.actor(TARGET_ID)
    hidden_still = []
    for t in np.arange(0.0, DEMO_DURATION_S, 0.25):
        tr = target.path.position(t)
        view = CameraView(math.atan2(tr[0], tr[1]), math.radians(-0.9), 8.0, 576, 504)  # follow it
        truth = target_truth(demo_scene, float(t), view)
        if truth.visible_fraction < 0.05 and target.path.velocity(t) == (0.0, 0.0):
            hidden_still.append(float(t))
    assert hidden_still, "the target never stands still while fully hidden"
    assert 9.0 < hidden_still[0] < 11.0


def test_target_visibility_is_head_independent_and_sees_the_wall(demo_scene) -> None:
    from swir_tracker_ros.scene.demo_scene import target_visibility

    vis = target_visibility(demo_scene, [0.5, 9.5, 13.0])
    assert vis[0] > 0.9 and vis[1] < 0.05 and vis[2] > 0.9


def _hidden_runs(scene, step: float = 0.1) -> list[tuple[float, float]]:
    """Scene-time runs (start, end) with less than half of the target visible."""
    from swir_tracker_ros.scene.demo_scene import target_visibility

    ts = np.arange(0.0, DEMO_DURATION_S, step)
    runs: list[list[float]] = []
    for t, v in zip(ts, target_visibility(scene, list(ts))):
        if v < 0.5:
            if runs and t - runs[-1][1] < 1.5 * step:
                runs[-1][1] = float(t)
            else:
                runs.append([float(t), float(t)])
    return [(a, b) for a, b in runs]


def test_scene_family_variants_are_harder_as_documented(demo_scene) -> None:
    """Each variant changes one thing against the demo scene, and the same seed gives the same frame."""
    base_runs = _hidden_runs(demo_scene)
    crossing = build_scene("demo_crossing", 7)
    assert any(4.5 < a < 5.5 for a, _b in _hidden_runs(crossing))  # the crosser covers the target at ~5 s
    assert not any(4.5 < a < 5.5 for a, _b in base_runs)
    crosser = crossing.world.actor(4)
    assert crosser.kind == "pedestrian" and crosser.look.upper < 0.25  # dark clothes, like the target
    long_runs = _hidden_runs(build_scene("demo_long_occlusion", 7))
    longest = max(b - a for a, b in long_runs)
    assert longest > 2.5 > max(b - a for a, b in base_runs) + 0.5
    long_scene = build_scene("demo_long_occlusion", 7)
    a, b = max(long_runs, key=lambda r: r[1] - r[0])
    path = long_scene.world.actor(TARGET_ID).path
    assert any(path.velocity(t)[1] > 0.5 for t in np.arange(a, b, 0.1))  # it turns away while hidden
    fast = build_scene("demo_fast", 7).world.actor(TARGET_ID).path
    slow = demo_scene.world.actor(TARGET_ID).path
    assert math.hypot(*fast.velocity(1.0)) == pytest.approx(1.6 * math.hypot(*slow.velocity(1.0)))
    view = CameraView(math.radians(2.4), math.radians(-0.9), 8.0, 576, 504)
    plain, _ = demo_scene.world.render(0.0, view)
    washed, _ = build_scene("demo_low_contrast", 7).world.render(0.0, view)
    assert np.std(washed.astype(float)) < 0.75 * np.std(plain.astype(float))
    shake = build_scene("demo_shake", 7)
    boxes = [target_truth(shake, t, view).box.x - target_truth(demo_scene, t, view).box.x
             for t in (0.0, 0.1, 0.2, 0.3)]
    assert max(map(abs, boxes)) > 0.5 and len({round(x, 2) for x in boxes}) > 1
    again, _ = build_scene("demo_shake", 7).world.render(0.3, view)
    first, _ = shake.world.render(0.3, view)
    assert np.array_equal(again, first)
    with pytest.raises(SceneError, match="unknown"):
        from swir_tracker_ros.scene.demo_world import demo_world

        demo_world(7, variant="nope")


def test_scene_clock_holds_until_started_and_at_the_end() -> None:
    clock = SceneClock(10.0)
    assert clock.time(100.0) == 0.0 and not clock.running
    assert clock.start(100.0) == 100.0
    assert clock.start(105.0) == 100.0  # idempotent
    assert clock.time(103.5) == pytest.approx(3.5)
    assert clock.time(200.0) == 10.0 and clock.finished(200.0)
    with pytest.raises(SceneError):
        SceneClock(0.0)


def test_build_scene_accepts_harness_scenarios_and_refuses_unknown_names() -> None:
    names = scene_names()
    assert names[0] == "demo" and set(VARIANTS) < set(names) and len(names) > len(VARIANTS) + 5
    other = build_scene(next(n for n in names if n not in VARIANTS), seed=1, bits=12, fps=25.0)
    assert other.duration_s > 0 and other.world.sensor.bits == 12
    with pytest.raises(SceneError, match="unknown scene"):
        build_scene("no_such_scene", seed=0)


def test_ground_truth_state_round_trip_and_camera_info() -> None:
    from msg_adapters.camera_info import intrinsics_from_camera_info
    from msg_adapters.errors import MessageError
    from msg_adapters.ground_truth import ground_truth_state_msg, ground_truth_state_values
    from msg_adapters.stamps import header
    from swir_tracker_ros.simulation.scene_camera_node import camera_info_msg, ground_truth_values

    scene = build_scene("demo", seed=7)
    view = CameraView(0.01, -0.005, 8.0, 576, 504)
    truth = target_truth(scene, 1.0, view)
    values = ground_truth_state_values(ground_truth_state_msg(header(12.5), ground_truth_values(
        1.0, truth, view, True)))
    assert values["scene_time"] == 1.0 and values["in_view"] == 1.0 and values["running"] == 1.0
    assert values["pan_error"] == pytest.approx(truth.azimuth - 0.01)
    assert values["tilt_error"] == pytest.approx(truth.elevation + 0.005)
    assert values["head_pan"] == pytest.approx(0.01)
    absent = ground_truth_state_values(ground_truth_state_msg(header(1.0), ground_truth_values(
        0.0, None, view, False)))
    assert absent["in_view"] == 0.0 and math.isnan(absent["pan_error"])
    assert values["pan_error"] == truth.azimuth - 0.01  # repr() text: the angle survives bit for bit
    with pytest.raises(MessageError, match="needs values"):
        ground_truth_state_msg(header(1.0), {"scene_time": 1.0})
    broken = ground_truth_state_msg(header(1.0), ground_truth_values(0.0, None, view, False))
    broken.status[0].values[0].value = "nan"  # scene_time
    with pytest.raises(MessageError, match="not finite"):
        ground_truth_state_values(broken)
    intr = intrinsics_from_camera_info(camera_info_msg(view, header(1.0)))
    assert (intr.fx, intr.cx, intr.cy, intr.width) == pytest.approx((view.fx, 288.0, 252.0, 576))


# --------------------------------------------------------------------------- the node as a process
def test_scene_camera_process_renders_at_the_head_pose(processes) -> None:
    """mono16 576x504; t holds at 0 until /scene/start; turning the head left moves the target right."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PolygonStamped
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import CameraInfo, Image, JointState
    from std_srvs.srv import Trigger

    from msg_adapters.geometry import box_from_polygon
    from msg_adapters.ground_truth import ground_truth_state_values
    from msg_adapters.joint_state import PanTiltSample, pan_tilt_to_joint_state

    proc = processes.start("scene_camera", "--ros-args", "-p", "autostart:=false", "-p", "extrapolate_s:=0.0")
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("scene_camera_probe", context=ctx)
    got: dict[str, list] = {"image": [], "info": [], "box": [], "state": []}
    node.create_subscription(Image, "/camera/image_raw", got["image"].append, qos_profile_sensor_data)
    node.create_subscription(CameraInfo, "/camera/camera_info", got["info"].append, qos_profile_sensor_data)
    node.create_subscription(PolygonStamped, "/ground_truth/box", got["box"].append, 10)
    node.create_subscription(DiagnosticArray, "/ground_truth/state", got["state"].append, 10)
    joints = node.create_publisher(JointState, "/positioner/joint_states", 10)
    start = node.create_client(Trigger, "/scene/start")
    from rclpy.executors import SingleThreadedExecutor

    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)

    def spin_until(pred, timeout: float) -> bool:
        return wait_for(lambda: (ex.spin_once(timeout_sec=0.02), pred())[1], timeout, interval=0.0)

    try:
        assert spin_until(lambda: len(got["state"]) >= 5 and got["image"], 60.0), processes.log(proc)
        img = got["image"][-1]
        assert (img.width, img.height, img.encoding) == (576, 504, "mono16")
        assert got["info"] and got["info"][-1].k[0] == pytest.approx(CameraView().fx)
        held = [ground_truth_state_values(m)["scene_time"] for m in got["state"]]
        assert held == [0.0] * len(held)  # paused until /scene/start
        box0 = box_from_polygon(got["box"][-1])
        assert box0 is not None and box0.cx < 288 - 100  # off-centre, to the left

        # Turn the head 2 degrees left: the scene (and the still target) moves right in the image.
        # Published until the camera has taken it: a single message may go out before the publisher and
        # the camera's subscription have matched.
        def turned() -> bool:
            pose = PanTiltSample(math.radians(2.0), 0.0, 0.0, 0.0, time.time())
            joints.publish(pan_tilt_to_joint_state(pose))
            box = box_from_polygon(got["box"][-1])
            return box is not None and abs(box.cx - box0.cx) > 1.0

        assert spin_until(turned, 20.0)
        n = len(got["box"])
        assert spin_until(lambda: len(got["box"]) >= n + 3, 20.0)
        box1 = box_from_polygon(got["box"][-1])
        assert box1.cx - box0.cx == pytest.approx(CameraView().fx * math.tan(math.radians(2.0)), rel=0.05)
        state = ground_truth_state_values(got["state"][-1])
        assert state["head_pan"] == pytest.approx(math.radians(2.0))

        assert start.wait_for_service(timeout_sec=10.0)
        future = start.call_async(Trigger.Request())
        assert spin_until(future.done, 10.0) and future.result().success
        m = len(got["state"])
        assert spin_until(lambda: len(got["state"]) >= m + 10, 20.0)
        assert ground_truth_state_values(got["state"][-1])["scene_time"] > 0.0
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    assert processes.stop(proc) == 0, processes.log(proc)
