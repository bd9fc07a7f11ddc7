# SPDX-License-Identifier: Apache-2.0
"""Simulation processes: the simulated SWIR camera on the head (`scene_camera`), rendering `scene/`.

Not part of the product graph: a real camera driver takes `scene_camera`'s place. Data flows one way:
`simulation` uses the scene library, the message adapters and the node toolkit (`nodes.runner`,
`nodes.ros_params`, `nodes.graph`); nothing in the product (core, nodes) imports it (docs/interfaces.md).
"""
