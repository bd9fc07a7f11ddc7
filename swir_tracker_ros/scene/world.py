# SPDX-License-Identifier: Apache-2.0
"""The angular world and its renderer: panorama remap, depth-sorted sprites, exact boxes and visibility."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from swir_tracker_ros.errors import SceneError
from swir_tracker_ros.scene.actors import Pedestrian, Placement, StaticOccluder, Vehicle
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.sensor import SensorModel, SensorPattern, apply_sensor, make_pattern, shake_offset
from swir_tracker_ros.scene.texture import Panorama
from swir_tracker_ros.types import Box

Object = Pedestrian | Vehicle | StaticOccluder


@dataclass(frozen=True)
class Truth:
    """Ground truth of one object with an identity in one rendered view.

    box: exact silhouette box in this view's pixels (continuous, may reach outside the image).
    visible_fraction: share of the silhouette that is inside the image and not covered by nearer objects.
    occlusion: share of the in-image silhouette covered by nearer objects (0 when nothing is in front).
    occluded: occlusion >= the world's `occlusion_threshold` (partial or full occlusion).
    """

    id: int
    kind: str
    box: Box
    visible_fraction: float
    occlusion: float
    occluded: bool
    in_view: bool
    range_m: float
    azimuth: float
    elevation: float

    @property
    def fully_occluded(self) -> bool:
        return self.in_view and self.visible_fraction < 0.05


@dataclass
class _Layer:
    range_m: float
    ys: slice
    xs: slice
    alpha: np.ndarray


@dataclass
class World:
    """Static background + objects on a ground plane seen from a camera `camera_height_m` above it."""

    panorama: Panorama
    objects: Sequence[Object]
    sensor: SensorModel = field(default_factory=SensorModel)
    seed: int = 0
    camera_height_m: float = 2.0
    occlusion_threshold: float = 0.1
    _patterns: dict = field(default_factory=dict, init=False, repr=False)

    @property
    def ids(self) -> list[int]:
        return [o.id for o in self.objects if not isinstance(o, StaticOccluder)]

    def actor(self, obj_id: int) -> Pedestrian | Vehicle:
        for o in self.objects:
            if not isinstance(o, StaticOccluder) and o.id == obj_id:
                return o
        raise SceneError(f"no object with id {obj_id}")

    def angles(self, p: Placement) -> tuple[float, float, float, float, float]:
        """(azimuth of the centre, half angular width, elevation of top, elevation of bottom, range)."""
        r = p.range_m
        return (math.atan2(p.x, p.y), math.atan2(p.width_m / 2.0, r),
                math.atan2(p.base_m + p.height_m - self.camera_height_m, r),
                math.atan2(p.base_m - self.camera_height_m, r), r)

    def box_in_view(self, p: Placement, view: CameraView) -> Box:
        az, hw, el_top, el_bot, _ = self.angles(p)
        u0, v0 = view.project(az + hw, el_top)
        u1, v1 = view.project(az - hw, el_bot)
        return Box(u0, v0, u1 - u0, v1 - v0)

    def _background(self, view: CameraView) -> np.ndarray:
        """Panorama resampled at every pixel's (azimuth, elevation); the maps of the last view are kept."""
        cached = self._patterns.get("maps")
        if cached is None or cached[0] != view:
            pano = self.panorama
            az, el = view.pixel_angles()
            mx = ((pano.az_max - az) / pano.res - 0.5).astype(np.float32)
            my = ((pano.el_max - el) / pano.res - 0.5).astype(np.float32)
            shape = (view.height, view.width)
            maps = cv2.convertMaps(np.ascontiguousarray(np.broadcast_to(mx[None, :], shape)),
                                   np.ascontiguousarray(np.broadcast_to(my[:, None], shape)), cv2.CV_16SC2)
            cached = (view, maps)
            self._patterns["maps"] = cached
        m1, m2 = cached[1]
        return cv2.remap(self.panorama.image, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)

    def _paint(self, img: np.ndarray, p: Placement, box: Box) -> _Layer | None:
        H, W = img.shape
        x0, y0 = max(0, math.floor(box.x)), max(0, math.floor(box.y))
        x1, y1 = min(W, math.ceil(box.x + box.w)), min(H, math.ceil(box.y + box.h))
        if x1 <= x0 or y1 <= y0 or box.w <= 0.5 or box.h <= 0.5:
            return None
        lvl = p.sprite.level_for(box.h)
        sh, sw = lvl.shape[:2]
        a, b = sw / box.w, sh / box.h
        ox = (x0 + 0.5 - box.x) * a - 0.5
        oy = (y0 + 0.5 - box.y) * b - 0.5
        M = np.array([[-a, 0.0, sw - 1 - ox], [0.0, b, oy]] if p.mirror else [[a, 0.0, ox], [0.0, b, oy]])
        warped = cv2.warpAffine(lvl, M, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        rad, alpha = warped[..., 0], warped[..., 1]
        region = img[y0:y1, x0:x1]
        region += alpha * (rad - region)
        return _Layer(p.range_m, slice(y0, y1), slice(x0, x1), alpha)

    def render_radiance(self, t: float, view: CameraView, background: np.ndarray | None = None
                        ) -> tuple[np.ndarray, list[Truth]]:
        """Scene radiance (float32 in [0, 1]) and truths at time t, without sensor effects.

        `background`: this view's panorama resampling, when the caller already has it (it is modified).
        """
        img = self._background(view) if background is None else background
        placed = [(o, o.place(t)) for o in self.objects]
        placed.sort(key=lambda op: -op[1].range_m)  # painter's algorithm: far first
        layers: list[tuple[Object, Placement, Box, _Layer | None]] = []
        for o, p in placed:
            box = self.box_in_view(p, view)
            layers.append((o, p, box, self._paint(img, p, box)))
        truths = []
        for i, (o, p, box, layer) in enumerate(layers):
            if isinstance(o, StaticOccluder):
                continue
            truths.append(self._truth(o, p, box, layer, layers[i + 1:], view))
        truths.sort(key=lambda tr: tr.id)
        return img, truths

    def _truth(self, o: Object, p: Placement, box: Box, layer: _Layer | None, nearer: list,
               view: CameraView) -> Truth:
        az, _, el_top, el_bot, r = self.angles(p)
        el = 0.5 * (el_top + el_bot)
        if layer is None:
            return Truth(o.id, o.kind, box, 0.0, 0.0, False, False, r, az, el)
        lvl = p.sprite.level_for(box.h)
        total = float(lvl[..., 1].mean()) * box.w * box.h
        inside = float(layer.alpha.sum())
        free = np.ones_like(layer.alpha)
        for _, _, _, other in nearer:
            if other is None:
                continue
            ys = slice(max(layer.ys.start, other.ys.start), min(layer.ys.stop, other.ys.stop))
            xs = slice(max(layer.xs.start, other.xs.start), min(layer.xs.stop, other.xs.stop))
            if ys.stop <= ys.start or xs.stop <= xs.start:
                continue
            a = other.alpha[ys.start - other.ys.start:ys.stop - other.ys.start,
                            xs.start - other.xs.start:xs.stop - other.xs.start]
            free[ys.start - layer.ys.start:ys.stop - layer.ys.start,
                 xs.start - layer.xs.start:xs.stop - layer.xs.start] *= 1.0 - a
        visible = float((layer.alpha * free).sum())
        occlusion = 1.0 - visible / inside if inside > 1e-6 else 0.0
        vis_frac = min(1.0, visible / total) if total > 1e-6 else 0.0
        return Truth(o.id, o.kind, box, vis_frac, occlusion, occlusion >= self.occlusion_threshold,
                     True, r, az, el)

    def pattern(self, width: int, height: int, sensor: SensorModel) -> SensorPattern:
        key = (width, height, sensor)
        if key not in self._patterns:
            self._patterns[key] = make_pattern(sensor, width, height, self.seed)
        return self._patterns[key]

    def render(self, t: float, view: CameraView, sensor: SensorModel | None = None
               ) -> tuple[np.ndarray, list[Truth]]:
        """Raw frame (uint8 for 8-bit, else uint16 at `sensor.bits`) and per-object truths at time t.

        Deterministic: the same (seed, t, view, sensor) gives the same frame. Camera shake moves the view
        (the truths follow it); interlacing exposes odd rows 0.5/fps later (truths are for the even field).
        """
        s = sensor or self.sensor
        if s.shake_px > 0:
            dx, dy = shake_offset(t, s.shake_px, self.seed)
            view = view.shifted(dx / view.fx, dy / view.fy)
        bg = self._background(view)
        late_bg = bg.copy() if s.interlaced else None
        img, truths = self.render_radiance(t, view, bg)
        if late_bg is not None:  # the head pose is per frame; only the objects move between the fields
            late, _ = self.render_radiance(t + 0.5 / s.fps, view, late_bg)
            img[1::2] = late[1::2]
        rng = np.random.default_rng([self.seed, 7200, round(t * 1e4) & 0x7FFFFFFF])
        return apply_sensor(img, s, self.pattern(view.width, view.height, s), rng), truths
