# SPDX-License-Identifier: Apache-2.0
"""Parameters of the closed-loop demo (params/demo.yaml) and where the package's params files live."""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from swir_tracker_ros.errors import DemoError, ParameterError
from swir_tracker_ros.nodes.param_docs import GENERATED, ParamsFile
from swir_tracker_ros.paramfield import param, validate_params
from swir_tracker_ros.scene.demo_scene import scene_names

PACKAGE = "swir_tracker_ros"


@dataclass(frozen=True)
class DemoParams:
    """What `demo` runs; the node parameters themselves come from params/<node>.yaml."""

    scene: str = param(
        "demo", "scene rendered by scene_camera: 'demo', a harder variant (demo_crossing, "
        "demo_long_occlusion, demo_fast, demo_low_contrast, demo_shake; docs/demo.md) or a harness scenario "
        "name (`harness synth --list`); `demo --scene NAME` overrides")
    seed: int = param(7, "scene seed (same seed, same scene); `demo --seed N` overrides", 0, 2**31 - 1)
    duration_s: float = param(
        30.0, "seconds of scene recorded per run (the demo scene lasts 30 s); `demo --duration S` overrides",
        1.0, 600.0)
    storage: str = param("mcap", "rosbag2 storage of the recording", choices=("mcap", "sqlite3"))
    bag_images: bool = param(
        False, "record /camera/image_raw in the bag (about 14 MB/s at 576x504 16-bit, 25 Hz: ~0.4 GB per "
        "run); off: the debug video (debug.mp4) carries the pictures; `demo --bag-images` turns it on")
    snapshots: list[float] = param(
        [2.0, 8.0, 16.0, 24.0], "scene times (s) at which a debug frame is saved as a PNG next to the video")
    startup_timeout_s: float = param(
        60.0, "seconds the processes may take to come up before the run is abandoned", 5.0, 600.0)
    sim_nice: int = param(
        0, "niceness added to the simulation-only processes (scene_camera's renderer and the recording "
        "demo_supervisor), process and session (autogroup); 0: none. A lower weight lets the tracker have "
        "the CPU first, but on a loaded machine the simulated camera then misses its 25 Hz (16-22 frames/s "
        "measured, 3-5 during a start-up), which a real camera never does", 0, 19)
    pelco_sim_args: list[str] = param(
        [], "extra pelco_sim command-line arguments (e.g. ['--latency', '0.05'] or ['--drop', '0.001'])")
    positioner_overrides: dict[str, object] = param(
        {"max_accel": 0.05}, "positioner_bridge parameters set on top of params/positioner.yaml for the "
        "demo. The head accelerates gently (3 deg/s^2): the tracker learns the head motion from joint states "
        "that arrive ~0.1-0.2 s late, and an abrupt start moves the image further between frames than that "
        "late ego-motion estimate covers (docs/demo.md)")
    tracker_overrides: dict[str, object] = param(
        {}, "tracker parameters set on top of params/tracker.yaml (core ones as tracker.<name>)")
    scene_camera_overrides: dict[str, object] = param(
        {}, "scene_camera parameters set on top of params/scene_camera.yaml")

    def validate(self) -> DemoParams:
        """Raise `DemoError` naming the first bad field (`paramfield.validate_params`); returns self."""
        try:
            validate_params(self)
        except ParameterError as exc:
            raise DemoError(f"demo {exc}") from None
        return self

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.scene not in scene_names():
            raise ParameterError(f"parameter scene = {self.scene!r} is not one of {scene_names()}")
        for name in ("positioner_overrides", "tracker_overrides", "scene_camera_overrides"):
            value = getattr(self, name)
            if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
                raise ParameterError(f"parameter {name} must map parameter names to values, got {value!r}")

    def with_duration(self, seconds: float) -> DemoParams:
        return dataclasses.replace(self, duration_s=float(seconds)).validate()

    def with_overrides(self, **values: object) -> DemoParams:
        """A copy with the given fields replaced (None: keep the current value), validated."""
        given = {k: v for k, v in values.items() if v is not None}
        if "duration_s" in given:
            given["duration_s"] = float(given["duration_s"])  # type: ignore[arg-type]
        return dataclasses.replace(self, **given).validate()


PARAMS_FILE = ParamsFile(
    "params/demo.yaml", "demo", (("", DemoParams, ""),),
    "Parameters of the closed-loop demo (`demo`, `make demo`; docs/demo.md), every one at its default. "
    + GENERATED + " swir_tracker_ros/demo/config.py, not this file. The nodes themselves read "
    "params/tracker.yaml, params/positioner.yaml and params/scene_camera.yaml.",
    ros_parameters=False)


def params_dir() -> Path:
    """params/ of a source checkout, else share/swir_tracker_ros/params of the install prefix."""
    source = Path(__file__).resolve().parents[2] / "params"
    if source.is_dir():
        return source
    installed = Path(sys.prefix) / "share" / PACKAGE / "params"
    if installed.is_dir():
        return installed
    try:
        from ament_index_python.packages import get_package_share_directory

        return Path(get_package_share_directory(PACKAGE)) / "params"
    except (ImportError, LookupError) as exc:
        raise DemoError(f"cannot find the {PACKAGE} params folder (looked in {source} and {installed})"
                        ) from exc


def dds_profile() -> Path | None:
    """The package's large-frame Fast DDS profile: shared memory and UDP (config/fastdds_shm_udp.xml,
    docs/interfaces.md)."""
    for base in (Path(__file__).resolve().parents[2], Path(sys.prefix) / "share" / PACKAGE):
        path = base / "config" / "fastdds_shm_udp.xml"
        if path.is_file():
            return path
    return None


def load_demo_params(path: Path | None = None) -> DemoParams:
    """DemoParams from the `demo:` mapping of a YAML file (default params/demo.yaml); unknown keys refused."""
    path = path or params_dir() / "demo.yaml"
    if not path.is_file():
        return DemoParams().validate()
    try:
        raw = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise DemoError(f"cannot read demo parameters {path}: {exc}") from exc
    values = raw.get("demo", raw) if isinstance(raw, dict) else None
    if not isinstance(values, dict):
        raise DemoError(f"{path} must hold a mapping `demo: {{key: value}}`")
    known = {f.name for f in dataclasses.fields(DemoParams)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise DemoError(f"{path}: unknown demo parameters {unknown}; known: {sorted(known)}")
    try:
        return DemoParams(**values).validate()
    except TypeError as exc:
        raise DemoError(f"{path}: {exc}") from exc
