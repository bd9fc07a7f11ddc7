# SPDX-License-Identifier: Apache-2.0
"""Objects on the ground plane: scripted paths, pedestrians, vehicles and static occluders."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from swir_tracker_ros.scene.texture import Look, Sprite, occluder_sprite, pedestrian_sprites, vehicle_sprite


@dataclass(frozen=True)
class Leg:
    """Walk for `duration` s at ground velocity (vx, vy) m/s; x is lateral (positive left), y is range.

    Speed changes, stops (0, 0) and turning back (negated velocity) are sequences of legs.
    """

    duration: float
    vx: float = 0.0
    vy: float = 0.0


@dataclass(frozen=True)
class Path:
    """Piecewise-constant-velocity path from `start` = (x, y) metres at t = `t0`; holds its last position."""

    start: tuple[float, float]
    legs: tuple[Leg, ...] = ()
    t0: float = 0.0

    @cached_property
    def _knots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = [self.t0]
        p = [self.start]
        for leg in self.legs:
            x, y = p[-1]
            t.append(t[-1] + leg.duration)
            p.append((x + leg.vx * leg.duration, y + leg.vy * leg.duration))
        dist = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(np.array(p), axis=0).T))]) if len(p) > 1 \
            else np.zeros(1)
        return np.array(t), np.array(p, dtype=np.float64), dist

    @property
    def end_time(self) -> float:
        return float(self._knots[0][-1])

    def position(self, t: float) -> tuple[float, float]:
        ts, ps, _ = self._knots
        return float(np.interp(t, ts, ps[:, 0])), float(np.interp(t, ts, ps[:, 1]))

    def velocity(self, t: float) -> tuple[float, float]:
        ts = self._knots[0]
        i = int(np.searchsorted(ts, t, side="right")) - 1
        if i < 0 or i >= len(self.legs):
            return 0.0, 0.0
        return self.legs[i].vx, self.legs[i].vy

    def distance(self, t: float) -> float:
        """Metres walked since t0 (drives the gait phase)."""
        ts, _, d = self._knots
        return float(np.interp(t, ts, d))


@dataclass(frozen=True)
class Placement:
    """Where an object stands at one instant: ground position, size and the sprite to draw."""

    x: float
    y: float
    width_m: float
    height_m: float
    base_m: float  # height of the sprite's bottom edge above the ground
    sprite: Sprite
    mirror: bool = False

    @property
    def range_m(self) -> float:
        return math.hypot(self.x, self.y)


@dataclass(frozen=True)
class Pedestrian:
    """A walking person with an identity; `look` sets its radiance (hot in thermal, dark clothes in SWIR)."""

    id: int
    path: Path
    height_m: float = 1.75
    width_m: float = 0.6
    look: Look = field(default_factory=Look)
    stride_m: float = 1.4
    seed: int = 0
    kind: str = "pedestrian"

    @cached_property
    def sprites(self) -> tuple[Sprite, ...]:
        return pedestrian_sprites(self.look, self.seed * 1009 + self.id)

    def place(self, t: float) -> Placement:
        x, y = self.path.position(t)
        vx, vy = self.path.velocity(t)
        speed = math.hypot(vx, vy)
        if speed < 1e-6:
            pose = 0
        else:
            phase = (self.path.distance(t) / self.stride_m) % 1.0
            pose = 1 + int(phase * (len(self.sprites) - 1)) % (len(self.sprites) - 1)
        # Seen from the front or back the silhouette is narrower than in profile.
        lateral = 1.0 if speed < 1e-6 else abs(vx) / speed
        width = self.width_m * (0.75 + 0.25 * lateral)
        return Placement(x, y, width, self.height_m, 0.0, self.sprites[pose], mirror=vx < 0)


@dataclass(frozen=True)
class Vehicle:
    """A car driving along its path (a moving occluder); it also has an identity and a ground-truth box."""

    id: int
    path: Path
    length_m: float = 4.5
    height_m: float = 1.5
    look: Look = field(default_factory=lambda: Look(head=0.15, upper=0.55, lower=0.1, texture=0.04))
    seed: int = 0
    kind: str = "vehicle"

    @cached_property
    def sprite(self) -> Sprite:
        return vehicle_sprite(self.look, self.seed * 1013 + self.id, aspect=self.length_m / self.height_m)

    def place(self, t: float) -> Placement:
        x, y = self.path.position(t)
        vx, _ = self.path.velocity(t)
        return Placement(x, y, self.length_m, self.height_m, 0.0, self.sprite, mirror=vx < 0)


@dataclass(frozen=True)
class StaticOccluder:
    """Pole, wall, tree or bush standing at ground position (x, y) metres."""

    kind: str
    x: float
    y: float
    width_m: float
    height_m: float
    look: Look = field(default_factory=lambda: Look(head=0.3, upper=0.3, lower=0.3, texture=0.05))
    seed: int = 0

    @cached_property
    def sprite(self) -> Sprite:
        seed = (self.seed * 1019 + int(self.x * 100) + int(self.y)) & 0x7FFFFFFF
        return occluder_sprite(self.kind, self.look, seed, self.width_m / self.height_m)

    def place(self, t: float) -> Placement:
        return Placement(self.x, self.y, self.width_m, self.height_m, 0.0, self.sprite)


def pole(x: float, y: float, height_m: float = 6.0, width_m: float = 0.35, **kw) -> StaticOccluder:
    return StaticOccluder("pole", x, y, width_m, height_m, **kw)


def wall(x: float, y: float, width_m: float = 6.0, height_m: float = 2.4, **kw) -> StaticOccluder:
    return StaticOccluder("wall", x, y, width_m, height_m, **kw)


def tree(x: float, y: float, width_m: float = 4.0, height_m: float = 6.0, **kw) -> StaticOccluder:
    kw.setdefault("look", Look(head=0.2, upper=0.24, lower=0.2, texture=0.07))
    return StaticOccluder("tree", x, y, width_m, height_m, **kw)


def bush(x: float, y: float, width_m: float = 3.0, height_m: float = 1.2, **kw) -> StaticOccluder:
    kw.setdefault("look", Look(head=0.25, upper=0.28, lower=0.25, texture=0.07))
    return StaticOccluder("bush", x, y, width_m, height_m, **kw)
