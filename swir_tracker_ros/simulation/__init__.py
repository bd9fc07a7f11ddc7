# SPDX-License-Identifier: Apache-2.0
"""Simulation processes: the simulated SWIR camera on the head (`scene_camera_node`, rendering `scene/`)
and the simulated Pelco-D pan-tilt head (`pelco_sim`, on a pty or loopback TCP port; no ROS).

Not part of the product graph: a real camera driver and a real head take their places. Data flows one way:
`simulation` uses the scene library, the Pelco-D protocol (`pelco/`), the message adapters and the node
toolkit (`nodes.runner`, `nodes.ros_params`, `nodes.graph`); nothing in the product (core, nodes) imports
it (docs/interfaces.md).
"""
