# SPDX-License-Identifier: Apache-2.0
"""The demo's built-in world: a pedestrian who stops behind a wall, a crossing car, and the demo family's
variants of it (each makes one thing harder)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from swir_tracker_ros.errors import SceneError
from swir_tracker_ros.scene.actors import Leg, Path, Pedestrian, Vehicle, pole, tree, wall
from swir_tracker_ros.scene.sensor import SensorModel
from swir_tracker_ros.scene.texture import Look, make_panorama
from swir_tracker_ros.scene.world import World

TARGET_ID = 1  # identity of the pedestrian the demo follows
DISTRACTOR_ID = 2
VEHICLE_ID = 3
CROSSER_ID = 4  # the same-kind pedestrian of the demo_crossing variant

# The target's path (ground metres: x lateral, positive to the camera's left; y range), ~1 m/s (about
# 57 px/s at 70 m with the 8 deg field of view). It starts 2.4 deg
# left of and 0.9 deg below the head's rest pose, so the head must turn both axes to centre it.
TARGET_LEGS: tuple[Leg, ...] = (
    Leg(9.9, vx=-1.0),  # strolls right; disappears behind the wall at ~9.2 s
    Leg(0.4),  # stops while hidden (a manoeuvre the Kalman prediction does not know about) ...
    Leg(2.7, vx=-1.2),  # ... walks on a little faster and reappears at ~10.6 s
    Leg(1.0, vy=-1.0),  # turns towards the camera
    Leg(7.0, vx=1.0),  # turns back, passes behind the wall again (~16.6-18 s); the car crosses at ~20 s
    Leg(9.0, vx=0.9, vy=0.4),  # walks away to the left, in the open
)
TARGET_START = (3.0, 70.0)
DEMO_DURATION_S = 30.0  # the scene's natural length (the target keeps walking after it)


def _scaled_legs(legs: tuple[Leg, ...], speed: float, total_s: float) -> tuple[Leg, ...]:
    """The same ground path walked `speed` times faster; the last leg is continued to `total_s` seconds."""
    fast = [Leg(leg.duration / speed, leg.vx * speed, leg.vy * speed) for leg in legs]
    walked = sum(leg.duration for leg in fast[:-1])
    fast[-1] = replace(fast[-1], duration=max(total_s - walked, fast[-1].duration))
    return tuple(fast)


# The target hides behind a wider wall for ~2.6 s and turns while hidden: it walks away from the camera
# for a second (its image shrinks and its sideways motion stops) before it walks on to the right.
LONG_OCCLUSION_LEGS: tuple[Leg, ...] = (
    Leg(9.4, vx=-1.0),  # strolls right; disappears behind the 2 m wall
    Leg(1.0, vy=1.0),  # turns away from the camera while hidden ...
    Leg(3.0, vx=-1.0),  # ... turns right again and reappears
    Leg(1.0, vy=-1.0),
    Leg(15.6, vx=0.9, vy=0.4),
)


@dataclass(frozen=True)
class Variant:
    """One scene of the demo family: what it makes harder than the demo scene."""

    name: str
    challenge: str


VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("demo", "the demo scene: two wall occlusions (one with a stop), a car crossing the legs"),
    Variant("demo_crossing", "a second dark-clothed pedestrian (same kind as the target) crosses in front "
                             "of it at ~5 s"),
    Variant("demo_long_occlusion", "a 2.6 m wall hides the target for ~2.6 s while it turns away and back"),
    Variant("demo_fast", "the demo path walked 1.6 times faster (1.6-1.9 m/s, ~95-110 px/s)"),
    Variant("demo_low_contrast", "washed-out SWIR scene: contrast 0.55, three times the temporal noise, "
                                 "target clothes closer to the background"),
    Variant("demo_shake", "camera shake of ~4 px on top of the head's motion"),
)}


def demo_world(seed: int = 7, bits: int = 16, fps: float = 25.0, variant: str = "demo") -> World:
    """The deterministic demo world (same seed, same scene) rendered by the `scene_camera` node.

    Occluders on the target's path: a wall (occlusion ~9.1-10.9 s, during which the target stops for
    0.4 s, and again ~16.6-18.0 s after it turned back) and a car crossing in front of its legs
    (~19.5-20.1 s, a moving occluder). A second pedestrian further away (clutter), a pole and a tree
    complete the scene. `variant` (a `VARIANTS` name) makes one thing harder; the seed changes the
    textures, the background and the noise, never the paths.
    """
    if variant not in VARIANTS:
        raise SceneError(f"unknown demo variant {variant!r}; known: {', '.join(VARIANTS)}")
    panorama = make_panorama(seed, az_span_deg=60.0, el_min_deg=-9.0, el_max_deg=5.0)
    legs, wall_width = TARGET_LEGS, 1.2
    look = Look(head=0.62, upper=0.2, lower=0.14, texture=0.05)
    sensor = SensorModel(bits=bits, noise=0.006, fpn=0.003, vignetting=0.12, fps=fps)
    if variant == "demo_long_occlusion":
        legs, wall_width = LONG_OCCLUSION_LEGS, 2.0
    elif variant == "demo_fast":
        legs = _scaled_legs(TARGET_LEGS, 1.6, DEMO_DURATION_S)
    elif variant == "demo_low_contrast":
        look = Look(head=0.55, upper=0.3, lower=0.26, texture=0.04)
        sensor = replace(sensor, contrast=0.55, noise=0.018, fpn=0.006)
    elif variant == "demo_shake":
        sensor = replace(sensor, shake_px=4.0)
    target = Pedestrian(TARGET_ID, Path(TARGET_START, legs), seed=seed, look=look)
    distractor = Pedestrian(DISTRACTOR_ID, Path((-30.0, 100.0), (Leg(40.0, vx=0.8),)), seed=seed,
                            look=Look(head=0.6, upper=0.26, lower=0.18, texture=0.05))
    car = Vehicle(VEHICLE_ID, Path((-82.0, 45.0), (Leg(40.0, vx=4.0),)), seed=seed)
    objects = [
        target,
        distractor,
        car,
        wall(-5.7, 58.0, width_m=wall_width, height_m=2.6, seed=seed),
        pole(-16.0, 60.0, height_m=6.0, width_m=0.35, seed=seed),  # scenery off the target's path
        tree(9.0, 62.0, width_m=2.6, height_m=5.5, seed=seed),
    ]
    if variant == "demo_crossing":
        # Same kind as the target (dark clothes, same size), 3 m nearer, strolling the other way: it passes
        # in front of the target at ~5 s (target x = -2.0 m) and covers most of it for ~0.4 s.
        objects.append(Pedestrian(CROSSER_ID, Path((-4.0, 67.0), (Leg(40.0, vx=0.4),)), seed=seed + 1,
                                  look=Look(head=0.6, upper=0.19, lower=0.15, texture=0.05)))
    return World(panorama=panorama, objects=objects, sensor=sensor, seed=seed)
