# SPDX-License-Identifier: Apache-2.0
"""Synthetic thermal crowds with identity ground truth, rendered by the scene package (`scene/`).

Warm pedestrians (`scene.actors.Pedestrian`, per-identity `Look` and texture, gait animation) and poles walk
on the ground plane in front of a static camera; `scene.world.World` paints them far to near, gives every
identity its exact box and visible fraction, and applies an 8-bit `SensorModel`. The scenes are staged in
image terms (columns, pixels per frame) because the acquisition tests reason in frames; `_ground_x` turns
an image column at a range into the lateral ground position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from swir_tracker_ros.acquisition.association import Detection
from swir_tracker_ros.scene.actors import Leg, Path, Pedestrian, StaticOccluder, pole
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.sensor import SensorModel
from swir_tracker_ros.scene.texture import Look, make_panorama
from swir_tracker_ros.scene.world import Truth, World
from swir_tracker_ros.types import Box

FPS = 25.0
# A 640x480 camera with a 20 deg field of view, 4 m above the ground and tilted 4.5 deg down: the horizon
# is near row 97 and a 1.75 m pedestrian is 60 px tall at 53 m, 170 px at 19 m.
VIEW = CameraView(pan=0.0, tilt=math.radians(-4.5), hfov_deg=20.0, width=640, height=480)
CAMERA_HEIGHT_M = 4.0
SENSOR = SensorModel(bits=8, noise=0.012, fpn=0.003, vignetting=0.1, fps=FPS)
WALK_S = 600.0  # length of a walker's last leg: it keeps walking long after any scene ends


@dataclass(frozen=True)
class CrowdScene:
    """Pedestrians (ids 1..n) and static occluders seen by a static camera (world built on first use)."""

    walkers: tuple[Pedestrian, ...] = ()
    occluders: tuple[StaticOccluder, ...] = ()
    seed: int = 0
    view: CameraView = VIEW
    camera_height_m: float = CAMERA_HEIGHT_M
    sensor: SensorModel = SENSOR
    fps: float = FPS

    @property
    def width(self) -> int:
        return self.view.width

    @property
    def height(self) -> int:
        return self.view.height

    @cached_property
    def world(self) -> World:
        """Thermal look: a cool, low-contrast background (hot people stand out), as `scene.crowd_world`."""
        v = self.view
        half_vfov = math.degrees(math.atan2(v.cy, v.fy))
        tilt = math.degrees(v.tilt)
        pano = make_panorama(self.seed, az_span_deg=2.0 * (abs(math.degrees(v.pan)) + v.hfov_deg),
                             el_min_deg=tilt - half_vfov - 1.5, el_max_deg=max(tilt + half_vfov, 0.0) + 1.5,
                             res_deg=0.025, brightness=0.25, contrast=0.5)
        return World(pano, (*self.walkers, *self.occluders), self.sensor, seed=self.seed,
                     camera_height_m=self.camera_height_m)


def render(scene: CrowdScene, k: int) -> tuple[np.ndarray, list[Truth]]:
    """Frame k (uint8) and the truth of every pedestrian at least partly inside the image (sorted by id)."""
    frame, truths = scene.world.render(k / scene.fps, scene.view)
    return frame, [tr for tr in truths if tr.in_view]


def thermal_look(rng: np.random.Generator) -> Look:
    """Random but distinct body temperatures (radiance of head, upper and lower body) and texture strength."""
    return Look(head=float(rng.uniform(0.85, 0.97)), upper=float(rng.uniform(0.5, 0.88)),
                lower=float(rng.uniform(0.42, 0.8)), texture=float(rng.uniform(0.03, 0.09)))


def _ground_x(u: float, range_m: float, view: CameraView = VIEW) -> float:
    """Lateral ground position (m, positive left) that the image column u shows at forward range range_m."""
    azimuth, _ = view.unproject(u, view.cy)
    return range_m * math.tan(azimuth)


def _speed(px_per_frame: float, range_m: float, view: CameraView = VIEW) -> float:
    """Ground speed (m/s) that moves a walker at range_m by px_per_frame image columns per frame."""
    return px_per_frame * FPS * range_m / view.fx


def _walker(ident: int, u0: float, range_m: float, legs: tuple[tuple[float, float], ...], look: Look,
            seed: int, height_m: float = 1.75, width_m: float = 0.6) -> Pedestrian:
    """A pedestrian centred on column u0 at frame 0 walking laterally: legs of (duration s, vx m/s)."""
    path = Path((_ground_x(u0, range_m), range_m), tuple(Leg(d, vx, 0.0) for d, vx in legs))
    return Pedestrian(ident, path, height_m=height_m, width_m=width_m, look=look, seed=seed)


def simulated_detections(gts: list[Truth], rng: np.random.Generator, *, min_visibility: float = 0.5,
                         miss_rate: float = 0.05, jitter: float = 0.04, fp_rate: float = 0.05,
                         size: tuple[int, int] = (640, 480)) -> list[Detection]:
    """Detector stand-in (notes seed-004 Section 6): visible GT boxes, misses, jitter, false positives."""
    dets = []
    for g in gts:
        if g.visible_fraction < min_visibility or rng.random() < miss_rate:
            continue
        b = g.box
        j = rng.normal(0.0, jitter, 4) * np.array([b.w, b.h, b.w, b.h])
        box = Box(b.x + j[0], b.y + j[1], b.w + j[2], b.h + j[3])
        dets.append(Detection(box, float(rng.uniform(0.6, 1.0))))
    if rng.random() < fp_rate:
        h = float(rng.uniform(40, 120))
        dets.append(Detection(Box(float(rng.uniform(0, size[0] - h / 2)), float(rng.uniform(0, size[1] - h)),
                                  h * 0.4, h), float(rng.uniform(0.3, 0.6))))
    return dets


def crossing_scene(seed: int = 0, frames: int = 80) -> CrowdScene:
    """Two pedestrians walking towards each other on nearly the same line (the left one 1 m nearer): they
    cross columns 70 <-> 570 in `frames` frames and the nearer one hides the other mid-way (Fig. 6)."""
    rng = np.random.default_rng(seed)
    a, b = thermal_look(rng), thermal_look(rng)
    y = 26.5 + float(rng.uniform(-2.0, 2.0))  # about 120 px tall
    t = frames / FPS
    walkers = []
    for ident, look, r, u0, u1 in ((1, a, y, 70.0, 570.0), (2, b, y + 1.0, 570.0, 70.0)):
        vx = (_ground_x(u1, r) - _ground_x(u0, r)) / t
        walkers.append(_walker(ident, u0, r, ((WALK_S, vx),), look, seed, 1.75 - 0.03 * (ident - 1)))
    return CrowdScene(tuple(walkers), seed=seed)


def meeting_scene(seed: int = 0, frames: int = 80) -> CrowdScene:
    """Two pedestrians walk towards each other (4 px per frame), overlap and both turn back where they meet
    at frame frames // 2: the motion model predicts that they pass, so only appearance can keep the
    identities."""
    rng = np.random.default_rng(seed)
    a, b = thermal_look(rng), thermal_look(rng)
    y = 26.5 + float(rng.uniform(-2.0, 2.0))
    meet = (frames // 2) / FPS
    walkers = []
    for ident, look, r, u_meet, sign in ((1, a, y, 312.0, -1.0), (2, b, y + 1.0, 328.0, 1.0)):
        v = sign * _speed(4.0, r)  # ground x is positive to the left: the left walker has v < 0
        u0 = u_meet + sign * 4.0 * (frames // 2)  # 4 px per frame for frames // 2 frames
        walkers.append(_walker(ident, u0, r, ((meet, v), (WALK_S, -v)), look, seed,
                               1.75 - 0.03 * (ident - 1)))
    return CrowdScene(tuple(walkers), seed=seed)


def occlusion_scene(seed: int = 0, occluded_frames: int = 10, *, occluder: bool = True,
                    start_u: float = 100.0) -> CrowdScene:
    """One pedestrian (100-120 px tall) walking right at 4 px per frame from column start_u behind a pole at
    the image centre that hides it completely for about occluded_frames frames (none with occluder=False)."""
    rng = np.random.default_rng(seed)
    look = thermal_look(rng)
    height_m, width_m = float(rng.uniform(1.6, 1.9)), float(rng.uniform(0.55, 0.72))
    range_m, step_px = 28.9, 4.0
    legs = ((WALK_S, -_speed(step_px, range_m)),)
    walker = _walker(1, start_u, range_m, legs, look, seed, height_m, width_m)
    if not occluder:
        return CrowdScene((walker,), seed=seed)
    # The pole is nearer; it covers the walker's box (plus two anti-aliased columns on each side) for
    # occluded_frames steps.
    pole_range = 20.0
    pole_px = width_m * VIEW.fx / range_m + step_px * occluded_frames + 4.0
    obstacle = pole(_ground_x(VIEW.cx, pole_range), pole_range, width_m=pole_px * pole_range / VIEW.fx,
                    seed=seed)
    return CrowdScene((walker,), (obstacle,), seed=seed)


def random_crowd(seed: int = 0, n: int = 6) -> CrowdScene:
    """n pedestrians 60-170 px tall (about 17-57 m away) entering from either side at 2-5 px per frame on
    straight paths that drift slowly in range (several crossings), and a pole (18 px wide) in front."""
    rng = np.random.default_rng(seed)
    walkers = []
    for i in range(n):
        look = thermal_look(rng)
        height_m, width_m = float(rng.uniform(1.6, 1.9)), float(rng.uniform(0.55, 0.72))
        range_m = height_m * VIEW.fy / float(rng.uniform(60.0, 170.0))
        left = rng.random() < 0.5
        u0 = float(rng.uniform(-20, 200)) if left else float(rng.uniform(440, 660))
        vx = _speed(float(rng.uniform(2.0, 5.0)), range_m) * (-1.0 if left else 1.0)
        vy = float(rng.uniform(-0.3, 0.3))
        path = Path((_ground_x(u0, range_m), range_m), (Leg(WALK_S, vx, vy),))
        walkers.append(Pedestrian(i + 1, path, height_m=height_m, width_m=width_m, look=look, seed=seed))
    pole_range = 15.0
    obstacle = pole(_ground_x(float(rng.uniform(200, 420)), pole_range), pole_range,
                    width_m=18.0 * pole_range / VIEW.fx, seed=seed)
    return CrowdScene(tuple(walkers), (obstacle,), seed=seed)
