# SPDX-License-Identifier: Apache-2.0
"""ROS 2 launch of one tracking head on real hardware: the tracker and the Pelco-D positioner bridge (and
the acquisition node when asked), all in the head's namespace. Nothing simulated is started.

    ros2 launch swir_tracker_ros bringup.launch.py namespace:=head1 port:=/dev/ttyUSB0 address:=1 \\
        image_topic:=/camera1/image_raw camera_info_topic:=/camera1/camera_info image_transport:=compressed

docs/bringup.md is the bring-up checklist (wiring, address, sign check, first track). The arguments and
the nodes are defined in `swir_tracker_ros/nodes/bringup.py` (`ros2 launch ... --show-args` lists them);
`python -m swir_tracker_ros.nodes.bringup <name>:=<value> ...` prints the same processes as commands.
"""

from __future__ import annotations

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription
from swir_tracker_ros.nodes.bringup import ARGUMENTS, PACKAGE, BringupArgs, bringup_nodes


def _head(context, *_args, **_kwargs):
    args = BringupArgs.from_text({a.name: LaunchConfiguration(a.name).perform(context) for a in ARGUMENTS})
    share = get_package_share_directory(PACKAGE)
    return [Node(package=PACKAGE, executable=spec.executable, name=spec.name, namespace=spec.namespace,
                 output="screen", parameters=[*spec.params_files, spec.overrides])
            for spec in bringup_nodes(args, share)]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *(DeclareLaunchArgument(a.name, default_value=a.default, description=a.description)
          for a in ARGUMENTS),
        OpaqueFunction(function=_head),
    ])
