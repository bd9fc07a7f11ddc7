# SPDX-License-Identifier: Apache-2.0
"""The scenes `scene_camera` renders (the demo family of scene/demo_world.py and the harness scenarios of
scene/scenarios.py, by name) and the scene clock."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from swir_tracker_ros.errors import SceneError
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_world import DEMO_DURATION_S, TARGET_ID, VARIANTS, demo_world
from swir_tracker_ros.scene.scenarios import TARGET_ID as SCENARIO_TARGET_ID
from swir_tracker_ros.scene.scenarios import scenarios
from swir_tracker_ros.scene.world import World


@dataclass(frozen=True)
class BuiltScene:
    """A world ready to render, its natural length and the identity of the pedestrian to follow."""

    name: str
    world: World
    duration_s: float
    target_id: int


def scene_names() -> list[str]:
    """The demo family (`VARIANTS`: 'demo' first) and every harness scenario name (`scene.scenarios`)."""
    return [*VARIANTS, *scenarios()]


def build_scene(name: str, seed: int, bits: int = 16, fps: float = 25.0) -> BuiltScene:
    """The demo world or a harness scenario's world, with the sensor's bit depth and frame rate set."""
    if name in VARIANTS:
        return BuiltScene(name, demo_world(seed, bits=bits, fps=fps, variant=name), DEMO_DURATION_S,
                          TARGET_ID)
    specs = scenarios()
    if name not in specs:
        raise SceneError(f"unknown scene {name!r}; known: {', '.join(scene_names())}")
    world = specs[name].build(seed)
    world.sensor = replace(world.sensor, bits=bits, fps=fps)
    return BuiltScene(name, world, specs[name].duration_s, SCENARIO_TARGET_ID)


class SceneClock:
    """Scene time from a wall clock: 0 until started, then seconds since the start, held at `duration_s`."""

    def __init__(self, duration_s: float, started_at: float | None = None) -> None:
        if not (duration_s > 0 and math.isfinite(duration_s)):
            raise SceneError(f"scene duration must be a positive number of seconds, got {duration_s}")
        self.duration_s = duration_s
        self.started_at = started_at

    @property
    def running(self) -> bool:
        return self.started_at is not None

    def start(self, now: float) -> float:
        """Start at `now` unless already started; returns the start time in force."""
        if self.started_at is None:
            self.started_at = now
        return self.started_at

    def time(self, now: float) -> float:
        if self.started_at is None:
            return 0.0
        return min(max(now - self.started_at, 0.0), self.duration_s)

    def finished(self, now: float) -> bool:
        return self.started_at is not None and now - self.started_at >= self.duration_s


def initial_target_box(scene: str = "demo", seed: int = 7, hfov_deg: float = 8.0, width: int = 576,
                       height: int = 504, pan: float = 0.0, tilt: float = 0.0) -> list[float]:
    """[x, y, w, h] of the target at scene time 0 seen from (pan, tilt): a `tracker` init_box parameter."""
    built = build_scene(scene, seed)
    actor = built.world.actor(built.target_id)
    box = built.world.box_in_view(actor.place(0.0), CameraView(pan, tilt, hfov_deg, width, height))
    return [round(box.x, 1), round(box.y, 1), round(box.w, 1), round(box.h, 1)]


def target_visibility(scene: BuiltScene, times: list[float] | tuple[float, ...], hfov_deg: float = 8.0,
                      width: int = 144, height: int = 126) -> list[float]:
    """Visible fraction of the target at each scene time, seen by a small camera centred on it.

    Occlusion in the angular world does not depend on where the head looks, so this is the same for
    every run of a scene: the demo scores occlusion episodes on it (a quarter-size view keeps it cheap).
    """
    world = scene.world
    actor = world.actor(scene.target_id)
    out = []
    for t in times:
        az, _hw, el_top, el_bot, _r = world.angles(actor.place(float(t)))
        view = CameraView(az, 0.5 * (el_top + el_bot), hfov_deg, width, height)
        _img, truths = world.render_radiance(float(t), view)
        out.append(next((tr.visible_fraction for tr in truths if tr.id == scene.target_id), 0.0))
    return out
