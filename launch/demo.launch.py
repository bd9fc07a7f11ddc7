# SPDX-License-Identifier: Apache-2.0
"""ROS 2 launch of the closed-loop demo graph: pelco_sim, positioner_bridge, scene_camera and tracker.

    ros2 launch swir_tracker_ros demo.launch.py [ego_motion_compensation:=false]
    ros2 launch swir_tracker_ros demo.launch.py sim_head:=false port:=/dev/ttyUSB0

Every node reads its params file from share/swir_tracker_ros/params. With sim_head:=true (default) the
simulated head serves a pty whose path is kept as a symlink at `sim_link`, and the bridge opens that link.
With the simulated head the tracker starts on the pedestrian with an init box computed from the scene at
the head's rest pose (init_from_scene:=auto, the default; with sim_head:=false nothing is selected: pick
the target on track/select, a click, or track/init). For a real head and camera use bringup.launch.py.
`demo` (docs/demo.md) runs the same graph without a ROS install and adds recording and the report.
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_prefix, get_package_share_directory
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction, SetEnvironmentVariable
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription

PACKAGE = "swir_tracker_ros"
EXECUTABLES = ("pelco_sim", "positioner_bridge", "scene_camera", "tracker")
PARAMS_FILES = ("positioner.yaml", "scene_camera.yaml", "tracker.yaml")


def _params(name: str) -> str:
    return os.path.join(get_package_share_directory(PACKAGE), "params", name)


def _truthy(text: str) -> bool:
    return text.strip().lower() in ("1", "true", "yes", "on")


def _graph(context, *_args, **_kwargs):
    arg = {name: LaunchConfiguration(name).perform(context) for name in (
        "ego_motion_compensation", "sim_head", "sim_link", "port", "scene", "seed", "init_from_scene",
        "max_accel")}
    port = arg["sim_link"] if _truthy(arg["sim_head"]) else arg["port"]
    tracker_overrides = {"ego_motion_compensation": _truthy(arg["ego_motion_compensation"])}
    init = arg["init_from_scene"].strip().lower()
    if _truthy(init) if init != "auto" else _truthy(arg["sim_head"]):
        from swir_tracker_ros.scene.demo_scene import initial_target_box

        tracker_overrides["init_box"] = initial_target_box(arg["scene"], int(arg["seed"]))
    pelco_sim = os.path.join(get_package_prefix(PACKAGE), "lib", PACKAGE, "pelco_sim")  # not a ROS node
    profile = os.path.join(get_package_share_directory(PACKAGE), "config", "fastdds_shm_udp.xml")
    env = ([SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", profile)]
           if os.path.isfile(profile) and "FASTRTPS_DEFAULT_PROFILES_FILE" not in os.environ else [])
    return [
        *env,  # full frames through a large shared-memory segment (docs/interfaces.md)
        ExecuteProcess(cmd=[pelco_sim, "--link", arg["sim_link"]], name="pelco_sim", output="screen",
                       condition=IfCondition(arg["sim_head"])),
        Node(package=PACKAGE, executable="positioner_bridge", name="positioner_bridge", output="screen",
             parameters=[_params("positioner.yaml"), {"port": port, "max_accel": float(arg["max_accel"])}]),
        Node(package=PACKAGE, executable="scene_camera", name="scene_camera", output="screen",
             parameters=[_params("scene_camera.yaml"), {"scene": arg["scene"], "seed": int(arg["seed"])}]),
        Node(package=PACKAGE, executable="tracker", name="tracker", output="screen",
             parameters=[_params("tracker.yaml"), tracker_overrides]),
    ]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument("ego_motion_compensation", default_value="true",
                              description="tracker shifts its prediction by the head motion"),
        DeclareLaunchArgument("sim_head", default_value="true",
                              description="start pelco_sim and drive it instead of a real head"),
        DeclareLaunchArgument("sim_link", default_value="/tmp/swir_tracker_pelco_sim",
                              description="symlink to the simulated head's pty"),
        DeclareLaunchArgument("port", default_value="/dev/ttyUSB0",
                              description="serial port or pyserial URL of a real head (sim_head:=false)"),
        DeclareLaunchArgument("max_accel", default_value="0.05",
                              description="head slew-rate limit, rad/s^2 (gentle starts keep ego-motion "
                              "compensation ahead of the image motion; docs/demo.md)"),
        DeclareLaunchArgument("scene", default_value="demo", description=(
            "scene rendered by scene_camera: demo, a harder variant (demo_crossing, demo_long_occlusion, "
            "demo_fast, demo_low_contrast, demo_shake) or a harness scenario")),
        DeclareLaunchArgument("seed", default_value="7", description="scene seed"),
        DeclareLaunchArgument("init_from_scene", default_value="auto", description=(
            "start tracking the scene's pedestrian on the first frame: true, false, or auto (true with "
            "sim_head, false with a real head: select the target on track/select or track/init)")),
        OpaqueFunction(function=_graph),
    ])
