# SPDX-License-Identifier: Apache-2.0
"""Scripted SWIR scenarios: one per challenge row of paper 000 Table 1, a no-occlusion control and extras."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from swir_tracker_ros.errors import SceneError
from swir_tracker_ros.scene.actors import Leg, Path, Pedestrian, Vehicle, bush, pole, tree, wall
from swir_tracker_ros.scene.camera import CameraView
from swir_tracker_ros.scene.demo_world import demo_world
from swir_tracker_ros.scene.sensor import SensorModel
from swir_tracker_ros.scene.texture import Look, make_panorama
from swir_tracker_ros.scene.world import Truth, World

TARGET_ID = 1
TILT = math.radians(-0.75)
DARK = Look(head=0.62, upper=0.2, lower=0.14, texture=0.05)  # dark clothes on a bright SWIR background


@dataclass(frozen=True)
class SceneFrame:
    """One rendered frame of a scenario: the image, all truths, the target's truth (None when not in view)."""

    index: int
    t: float
    image: np.ndarray
    truths: list[Truth]
    target: Truth | None
    view: CameraView

    @property
    def occluded(self) -> bool:
        return self.target is not None and self.target.occluded


@dataclass(frozen=True)
class ScenarioSpec:
    """A named scenario: the challenges it stages, its paper 000 Table 1 row, length and camera mode."""

    name: str
    challenges: str
    table1_row: int | None
    duration_s: float
    build: Callable[[int], World] = field(repr=False)
    camera: str = "static"  # "static" or "follow" (scripted pan that lags the target)
    pan0: float = 0.0
    jerk: tuple[float, float] | None = None  # (time s, pan step rad): a sudden camera movement
    default_seed: int = 0
    hfov_deg: float = 8.0


@dataclass
class ScenarioRun:
    """A built scenario: world, per-frame camera views, and rendering by frame index."""

    spec: ScenarioSpec
    world: World
    views: list[CameraView]
    fps: float = 25.0
    target_id: int = TARGET_ID

    @property
    def n_frames(self) -> int:
        return len(self.views)

    def frame(self, k: int) -> SceneFrame:
        t = k / self.fps
        image, truths = self.world.render(t, self.views[k])
        target = next((tr for tr in truths if tr.id == self.target_id and tr.in_view), None)
        return SceneFrame(k, t, image, truths, target, self.views[k])

    def __iter__(self) -> Iterator[SceneFrame]:
        for k in range(self.n_frames):
            yield self.frame(k)


def _views(spec: ScenarioSpec, world: World, fps: float) -> list[CameraView]:
    n = round(spec.duration_s * fps)
    hfov_deg = spec.hfov_deg
    if spec.camera == "static":
        return [CameraView(spec.pan0, TILT, hfov_deg)] * n
    target = world.actor(TARGET_ID)
    gain = 1.0 - math.exp(-1.0 / (fps * 0.8))  # first-order lag, time constant 0.8 s
    x, y = target.path.position(0.0)
    pan = math.atan2(x, y) + spec.pan0
    views = []
    for k in range(n):
        x, y = target.path.position(k / fps)
        pan += gain * (math.atan2(x, y) - pan)
        jump = spec.jerk[1] if spec.jerk and k / fps >= spec.jerk[0] else 0.0
        views.append(CameraView(pan + jump, TILT, hfov_deg))
    return views


def make_scenario(name: str, seed: int | None = None, fps: float = 25.0) -> ScenarioRun:
    """Build scenario `name` (see `scenarios()`); the same seed always gives the same frames."""
    specs = scenarios()
    if name not in specs:
        raise SceneError(f"unknown scenario {name!r}; known: {', '.join(specs)}")
    spec = specs[name]
    s = spec.default_seed if seed is None else seed
    world = spec.build(s)
    world.sensor = replace(world.sensor, fps=fps)
    return ScenarioRun(spec, world, _views(spec, world, fps), fps)


def _walker(legs: list[tuple[float, float, float]], start: tuple[float, float], pid: int = TARGET_ID,
            look: Look = DARK, seed: int = 0, height: float = 1.75) -> Pedestrian:
    path = Path(start, tuple(Leg(*leg) for leg in legs))
    return Pedestrian(pid, path, height_m=height, look=look, seed=seed)


def _world(seed: int, objects: list, sensor: SensorModel | None = None, contrast: float = 1.0) -> World:
    return World(make_panorama(seed, contrast=contrast), objects, sensor or SensorModel(), seed=seed)


def _row1(seed: int) -> World:
    tgt = _walker([(4.0, 1.1, 0.0), (3.0, 0.3, -2.0), (5.5, 1.1, 0.0), (3.5, 0.9, 1.0)], (-8.0, 110.0),
                  seed=seed)
    return _world(seed, [tgt, pole(-3.34, 70.0, width_m=0.7), wall(0.8, 55.0, width_m=2.0),
                         tree(9.0, 80.0), bush(-9.0, 60.0)])


def _row2(seed: int) -> World:
    tgt = _walker([(6.0, 1.4, 0.0), (1.0, 0.0, 0.0), (5.0, -1.4, 0.0), (4.0, 0.5, -1.2)], (-5.0, 100.0),
                  seed=seed)
    return _world(seed, [tgt, bush(-1.5, 55.0, width_m=2.0, height_m=1.0), pole(2.0, 65.0, width_m=0.6),
                         tree(-8.0, 75.0)])


def _row3(seed: int) -> World:
    # Speeds up, stops behind the wall for 2 s (manoeuvre while hidden), then continues slowly.
    tgt = _walker([(3.5, 1.1, 0.0), (1.0, 2.0, 0.0), (2.0, 0.0, 0.0), (1.5, 1.5, 0.0), (7.0, 0.9, 0.0)],
                  (-8.5, 105.0), seed=seed)
    return _world(seed, [tgt, wall(-1.0, 55.0, width_m=3.2), pole(6.0, 70.0), bush(-9.0, 50.0)])


def _row4(seed: int) -> World:
    tgt = _walker([(14.0, 1.2, 0.0)], (-7.0, 110.0), seed=seed)
    twin = _walker([(14.0, 1.15, 0.0)], (-8.6, 112.0), pid=2, seed=seed)  # clutter: a similar pedestrian
    return _world(seed, [tgt, twin, pole(-0.5, 75.0, width_m=0.6), tree(8.0, 85.0)],
                  SensorModel(shake_px=5.0))


def _row5(seed: int) -> World:
    tgt = _walker([(18.0, 1.3, 0.0)], (-12.0, 100.0), seed=seed)
    return _world(seed, [tgt, bush(-5.0, 60.0, width_m=2.5), pole(-3.5, 70.0, width_m=0.7),
                         tree(0.5, 65.0, width_m=3.0), wall(3.0, 55.0, width_m=3.5)],
                  SensorModel(interlaced=True))


def _row6(seed: int) -> World:
    tgt = _walker([(3.0, 1.2, 0.0), (2.0, 1.0, -1.0), (2.0, 2.2, 0.0), (1.0, 0.0, 0.0), (3.0, -1.3, 0.0),
                   (2.0, 0.5, 1.2), (4.0, 1.6, 0.0)], (-5.0, 100.0), seed=seed)
    return _world(seed, [tgt, bush(-1.5, 55.0, width_m=2.0, height_m=1.0), pole(1.0, 60.0, width_m=0.6),
                         pole(5.5, 60.0, width_m=0.6), tree(-9.0, 70.0)],
                  SensorModel(dead_pixels=0.002))


def _row7(seed: int) -> World:
    # Walks diagonally towards the camera: the box roughly doubles in height.
    tgt = _walker([(17.0, 0.9, -4.5)], (-8.0, 160.0), seed=seed)
    return _world(seed, [tgt, bush(-6.0, 90.0, width_m=2.0, height_m=1.0), bush(-3.0, 70.0, width_m=2.0),
                         wall(1.75, 50.0, width_m=1.6), tree(10.0, 70.0)])


def _row8(seed: int) -> World:
    tgt = _walker([(16.0, 1.3, 0.0)], (-10.0, 110.0), seed=seed)
    p2 = _walker([(16.0, -1.2, 0.0)], (6.0, 70.0), pid=2, seed=seed, look=Look(0.6, 0.5, 0.3, 0.05))
    p3 = _walker([(16.0, -1.0, 0.0)], (12.0, 85.0), pid=3, seed=seed, look=Look(0.6, 0.35, 0.45, 0.05))
    return _world(seed, [tgt, p2, p3, pole(-5.0, 70.0, width_m=0.7), bush(1.0, 60.0, width_m=2.0),
                         wall(7.5, 55.0, width_m=2.2)])


def _row9(seed: int) -> World:
    tgt = _walker([(16.0, 1.25, 0.0)], (-10.0, 105.0), seed=seed)
    twin = _walker([(4.0, 0.0, 0.0), (12.0, 1.3, 0.0)], (-4.0, 108.0), pid=2, seed=seed)  # clutter
    van = Vehicle(3, Path((28.0, 70.0), (Leg(16.0, -6.0, 0.0),)), length_m=5.5, height_m=2.6, seed=seed)
    p4 = _walker([(16.0, -1.1, 0.0)], (10.0, 75.0), pid=4, seed=seed, look=Look(0.6, 0.5, 0.35, 0.05))
    return _world(seed, [tgt, twin, van, p4, tree(-14.0, 80.0)], SensorModel(bits=16, noise=0.01))


def _control(seed: int) -> World:
    tgt = _walker([(6.0, 1.1, 0.0), (3.0, 0.7, -1.0), (5.0, 1.1, 0.0)], (-7.0, 100.0), seed=seed)
    return _world(seed, [tgt, pole(9.0, 60.0), tree(-12.0, 70.0), bush(8.0, 50.0)])


def _low_contrast(seed: int) -> World:
    look = Look(head=0.5, upper=0.4, lower=0.37, texture=0.03)
    tgt = _walker([(4.0, 1.0, 0.0), (4.0, 1.2, 0.0), (6.0, 1.0, 0.0)], (-7.5, 100.0), look=look, seed=seed)
    return _world(seed, [tgt, wall(-0.5, 55.0, width_m=2.5), bush(-3.0, 60.0, width_m=2.0)],
                  SensorModel(contrast=0.5, noise=0.012, interlaced=True), contrast=0.6)


def _lookalike(seed: int) -> World:
    # The demo_crossing world (its first 8 s): a pedestrian of the target's look and size, 3 m nearer,
    # strolls the other way and passes in front of it at ~5 s, covering up to 70 % of it for ~0.4 s.
    return demo_world(seed, variant="demo_crossing")


def scenarios() -> dict[str, ScenarioSpec]:
    """The harness scenarios by name (t1..t9 = paper 000 Table 1 rows 1-9)."""
    specs = [
        ScenarioSpec("t1_full_static_size", "short- and long-term full static occlusions, orientation and "
                     "size changes", 1, 16.0, _row1, hfov_deg=11.0),
        ScenarioSpec("t2_partial_full_turn_back", "short-term partial and full static occlusions, "
                     "orientation and direction changes (turns back)", 2, 15.0, _row2),
        ScenarioSpec("t3_long_full_dynamics", "long-term full static occlusion, speed changes and a stop "
                     "while hidden", 3, 15.0, _row3, hfov_deg=11.0),
        ScenarioSpec("t4_clutter_shake", "clutter (similar pedestrian close by), short-term occlusion, "
                     "camera shake", 4, 13.0, _row4, hfov_deg=11.0),
        ScenarioSpec("t5_partial_full_pan", "short/long, partial/full static occlusions; panning camera, "
                     "interlaced, a sudden camera jerk", 5, 18.0, _row5, camera="follow", jerk=(11.0, 0.01)),
        ScenarioSpec("t6_orientation_dynamics_pan", "short-term partial and full static occlusions, "
                     "orientation and motion-dynamics changes; panning camera, dead pixels", 6, 16.0, _row6,
                     camera="follow"),
        ScenarioSpec("t7_long_full_size_pan", "one long-term full and several partial static occlusions, "
                     "size change (approaching); panning camera", 7, 16.0, _row7, camera="follow"),
        ScenarioSpec("t8_moving_partial_pan", "partial and full static occlusions, several partial moving "
                     "occlusions (pedestrians); panning camera", 8, 15.0, _row8, camera="follow"),
        ScenarioSpec("t9_clutter_moving_full_pan", "clutter, partial and full moving occlusions (pedestrian, "
                     "car); panning camera, 16-bit", 9, 15.0, _row9, camera="follow"),
        ScenarioSpec("control_no_occlusion", "walking with a turn, no occlusion (control)", None, 14.0,
                     _control, hfov_deg=11.0),
        ScenarioSpec("x_low_contrast_interlaced", "very low contrast, interlaced, long full static occlusion",
                     None, 14.0, _low_contrast, hfov_deg=11.0),
        ScenarioSpec("x_lookalike_crossing", "a pedestrian of the target's look crosses in front of it the "
                     "other way (the box must not leave with it); panning camera", None, 8.0, _lookalike,
                     camera="follow", default_seed=4),
    ]
    return {s.name: s for s in specs}


def crowd_world(seed: int, n: int = 12, thermal: bool = True, area: tuple[float, float, float, float] =
                (-25.0, 25.0, 60.0, 160.0), duration_s: float = 120.0, occluders: int = 4) -> World:
    """Several pedestrians with ids 1..n wandering (walk, stop, turn back) in x0..x1, y0..y1 metres.

    thermal=True renders people hot on a cool background (thermal look); False gives the SWIR look.
    """
    rng = np.random.default_rng([seed, 7300])
    x0, x1, y0, y1 = area
    objs: list = []
    for pid in range(1, n + 1):
        legs, t = [], 0.0
        while t < duration_s:
            d = float(rng.uniform(2.0, 8.0))
            if rng.random() < 0.15:
                legs.append((d, 0.0, 0.0))
            else:
                sp, hd = float(rng.uniform(0.6, 1.8)), float(rng.uniform(0, 2 * math.pi))
                legs.append((d, sp * math.cos(hd) * 1.0, sp * math.sin(hd) * 0.5))
            t += d
        start = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
        look = (Look(head=0.95, upper=float(rng.uniform(0.7, 0.9)), lower=float(rng.uniform(0.6, 0.85)),
                     texture=0.04) if thermal else
                Look(head=0.6, upper=float(rng.uniform(0.1, 0.6)), lower=float(rng.uniform(0.1, 0.5)),
                     texture=0.05))
        objs.append(_walker(legs, start, pid=pid, look=look, seed=seed, height=float(rng.uniform(1.55, 1.9))))
    for _ in range(occluders):
        kind = rng.choice(["pole", "tree", "bush", "wall"])
        x, y = float(rng.uniform(x0, x1)), float(rng.uniform(y0 * 0.6, y0))
        objs.append({"pole": pole, "tree": tree, "bush": bush, "wall": wall}[str(kind)](x, y))
    pano = make_panorama(seed, brightness=0.25 if thermal else 0.42, contrast=0.5 if thermal else 1.0)
    return World(pano, objs, SensorModel(bits=16 if thermal else 12), seed=seed)
