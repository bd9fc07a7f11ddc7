# SPDX-License-Identifier: Apache-2.0
"""Closed-loop pan-tilt demo: the built-in scene, process orchestration, recording, scoring and the report.

`demo --out DIR [--duration S] [--no-ego-compare]` (`run.main`) starts `pelco_sim`, `positioner_bridge`,
`scene_camera`, `tracker` and a recording supervisor (`swir_tracker_ros.demo.supervisor_node`) as
separate processes on a per-run ROS_DOMAIN_ID with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, once with and
once without ego-motion compensation, and writes the bag, the debug video, plots and a report (docs/demo.md).

Modules: `processes` (start / stop), `supervisor_node` (records the run, initialises the track, starts the
scene), `recording` (rosbag2 writer and per-run records), `video`, `analysis` (scores), `report` (plots,
JSON, Markdown, HTML), `config` (params/demo.yaml), `run` (the command), `sweep` (many seeds). The scene
itself is simulation: `scene.demo_scene` (world and clock) rendered by `simulation.scene_camera_node`.
"""
