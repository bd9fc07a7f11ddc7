# SPDX-License-Identifier: Apache-2.0
"""Synthetic SWIR world in angular coordinates: pedestrians with identities, occluders, sensor effects.

Stable API (the harness, the demo's ``scene_camera`` node and the acquisition crowd scenes use it)
-------------------------------------------------------------------------------------------------
Coordinates
    Ground plane in metres seen from a camera ``World.camera_height_m`` (2 m) above it: ``x`` lateral,
    positive to the LEFT, ``y`` range (forward). Angles in radians with the signs of docs/interfaces.md:
    azimuth ``atan2(x, y)`` and pan positive to the left, elevation and tilt positive upwards.

``CameraView(pan=0.0, tilt=0.0, hfov_deg=8.0, width=576, height=504)``  (frozen dataclass)
    Pinhole view at a head pose; principal point at the image centre, square pixels.
    ``project(az, el) -> (u, v)`` (``u = cx - fx tan(az - pan)``), ``unproject(u, v) -> (az, el)``,
    ``fx, fy, cx, cy``, ``shifted(dpan, dtilt)``, ``camera_info()`` (K, D for a CameraInfo adapter).

``World(panorama, objects, sensor=SensorModel(), seed=0, camera_height_m=2.0, occlusion_threshold=0.1)``
    ``render(t, view, sensor=None) -> (frame, truths)``: ``frame`` is ``uint16`` counts at
    ``sensor.bits`` (``uint8`` when ``bits == 8``), shape ``(height, width)``; ``truths`` is a list of
    ``Truth`` sorted by id, one per pedestrian/vehicle (static occluders have none).
    ``render_radiance(t, view)`` gives float32 radiance in [0, 1] without sensor effects.
    Deterministic: the same (seed, t, view, sensor) always gives the same frame. About 5-7 ms per
    576x504 frame (`python -m swir_tracker_ros.scene NAME` prints it); twice that with interlacing.
    ``ids``, ``actor(id)``, ``box_in_view(placement, view)``.

``Truth(id, kind, box, visible_fraction, occlusion, occluded, in_view, range_m, azimuth, elevation)``
    ``box``: exact ``types.Box`` of the silhouette in that view's pixels (continuous, pixel (i, j) covers
    [i, i+1) x [j, j+1); may reach outside the image). ``visible_fraction``: share of the silhouette inside
    the image and not covered by nearer objects. ``occlusion``: share of the in-image silhouette covered by
    nearer objects. ``occluded``: ``occlusion >= occlusion_threshold``; ``fully_occluded``: visible < 5 %.

Objects (frozen dataclasses, ``actors.py``)
    ``Pedestrian(id, path, height_m=1.75, width_m=0.6, look=Look(), stride_m=1.4, seed=0)`` (gait
    animation, narrower when walking towards/away from the camera, scale from range);
    ``Vehicle(id, path, length_m=4.5, height_m=1.5, ...)``; ``StaticOccluder`` via ``pole(x, y)``,
    ``wall(x, y)``, ``tree(x, y)``, ``bush(x, y)``.
    ``Path(start=(x, y), legs=(Leg(duration, vx, vy), ...))``: walk, stop (``Leg(d)``), turn back
    (negated velocity), speed changes; holds the last position after the legs end.
    ``Look(head, upper, lower, texture)``: radiance in [0, 1] of the parts (hot people for thermal).

``SensorModel(bits=12, noise=0.008, fpn=0.004, dead_pixels=0.0, contrast=1.0, offset=0.0,
vignetting=0.15, interlaced=False, shake_px=0.0, fps=25.0)``  (``sensor.py``)

``make_panorama(seed, az_span_deg=50, el_min_deg=-9, el_max_deg=5, res_deg=0.014, brightness, contrast)``
    The background (sky, skyline, textured ground), built once per world (~0.5-1 s).

Scenarios (``scenarios.py``)
    ``scenarios() -> {name: ScenarioSpec}``: ``t1..t9`` = paper 000 Table 1 rows 1-9,
    ``control_no_occlusion`` and ``x_low_contrast_interlaced``; the target is id ``TARGET_ID`` (1).
    ``make_scenario(name, seed=None, fps=25.0) -> ScenarioRun`` with ``world``, ``views`` (one
    ``CameraView`` per frame, static or a scripted pan lagging the target), ``n_frames``, ``fps`` and
    ``frame(k) -> SceneFrame(index, t, image, truths, target, view)`` (``target`` None when out of view,
    ``occluded`` = the per-frame occlusion flag); iterating a run yields every frame.
    ``crowd_world(seed, n=12, thermal=True, ...)``: ids 1..n pedestrians wandering over a wide area;
    ``demo_world(seed, variant="demo")`` (``demo_world.py``): the closed-loop demo world and its family.

Crowd scenes (``crowd.py``, imported on its own: ``from swir_tracker_ros.scene import crowd``)
    The acquisition tests' and benchmarks' thermal crowds, staged in image columns with these actors,
    textures and sensor model, plus a detector stand-in; a fixture, not runtime acquisition code.
"""

from __future__ import annotations

from swir_tracker_ros.scene.actors import (
    Leg,
    Path,
    Pedestrian,
    StaticOccluder,
    Vehicle,
    bush,
    pole,
    tree,
    wall,
)
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_world import demo_world
from swir_tracker_ros.scene.scenarios import (
    TARGET_ID,
    ScenarioRun,
    ScenarioSpec,
    SceneFrame,
    crowd_world,
    make_scenario,
    scenarios,
)
from swir_tracker_ros.scene.sensor import SensorModel
from swir_tracker_ros.scene.texture import Look, Panorama, make_panorama
from swir_tracker_ros.scene.world import Truth, World

__all__ = [
    "TARGET_ID", "CameraView", "Leg", "Look", "Panorama", "Path", "Pedestrian", "ScenarioRun", "ScenarioSpec",
    "SceneFrame", "SensorModel", "StaticOccluder", "Truth", "Vehicle", "World", "bush", "crowd_world",
    "demo_world", "make_panorama", "make_scenario", "pole", "scenarios", "tree", "wall",
]
