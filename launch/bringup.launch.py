# SPDX-License-Identifier: Apache-2.0
"""ROS 2 launch of one tracking head on real hardware: the tracker, the Pelco-D positioner bridge and
robot_state_publisher (the head's URDF; TF from its joint states), and the acquisition node when asked, all in
the head's namespace. Nothing simulated is started.

    ros2 launch swir_tracker_ros bringup.launch.py namespace:=head1 port:=/dev/ttyUSB0 address:=1 \\
        image_topic:=/camera1/image_raw image_transport:=compressed pan_joint:=head1_pan managed:=true

docs/bringup.md is the bring-up checklist (wiring, address, sign check, first track). The arguments and
the nodes are defined in `swir_tracker_ros/nodes/bringup.py` (`ros2 launch ... --show-args` lists them);
`python -m swir_tracker_ros.nodes.bringup <name>:=<value> ...` prints the same processes as commands. Every
node gets the Fast DDS profile `dds_profile` (large shared memory AND UDP, docs/interfaces.md); with
managed:=true the bridge is a lifecycle node, configured at start and activated once it is inactive.
"""

from __future__ import annotations

from ament_index_python.packages import get_package_share_directory
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    OpaqueFunction,
    RegisterEventHandler,
    SetEnvironmentVariable,
)
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode, Node
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from lifecycle_msgs.msg import Transition

from launch import LaunchDescription
from swir_tracker_ros.nodes.bringup import (
    ARGUMENTS,
    PACKAGE,
    RESPAWN_DELAY_S,
    BringupArgs,
    bringup_nodes,
    dds_profile,
)

TRANSITIONS = {"configure": Transition.TRANSITION_CONFIGURE, "activate": Transition.TRANSITION_ACTIVATE}
# the state a node is in once the transition has completed: the next one is sent then
REACHED = {"configure": "inactive", "activate": "active"}


def _change(node, transition: str) -> EmitEvent:
    return EmitEvent(event=ChangeState(lifecycle_node_matcher=lambda action, n=node: action is n,
                                       transition_id=TRANSITIONS[transition]))


def _head(context, *_args, **_kwargs):
    args = BringupArgs.from_text({a.name: LaunchConfiguration(a.name).perform(context) for a in ARGUMENTS})
    share = get_package_share_directory(PACKAGE)
    profile = dds_profile(args, share)
    actions = [SetEnvironmentVariable("FASTRTPS_DEFAULT_PROFILES_FILE", profile)] if profile else []
    for spec in bringup_nodes(args, share):
        ros_arguments = ["--log-level", spec.log_level] if spec.log_level else []
        common = {"package": spec.package, "executable": spec.executable, "name": spec.name,
                  "namespace": spec.namespace, "output": "screen", "parameters": [*spec.params_files,
                                                                               spec.overrides],
                  "remappings": list(spec.remappings), "arguments": list(spec.arguments),
                  "ros_arguments": ros_arguments, "respawn": spec.respawn, "respawn_delay": RESPAWN_DELAY_S}
        if not spec.lifecycle:
            actions.append(Node(**common))
            continue
        node = LifecycleNode(**common)
        actions.append(node)
        for done, following in zip(spec.lifecycle, spec.lifecycle[1:]):  # each transition once the last is
            actions.append(RegisterEventHandler(OnStateTransition(
                target_lifecycle_node=node, goal_state=REACHED[done], entities=[_change(node, following)])))
        actions.append(_change(node, spec.lifecycle[0]))
    return actions


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        *(DeclareLaunchArgument(a.name, default_value=a.default, description=a.description)
          for a in ARGUMENTS),
        OpaqueFunction(function=_head),
    ])
