"""ament_python build of swir_tracker_ros; the same entry points work from a pip install."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "swir_tracker_ros"

# Console scripts: `ros2 run swir_tracker_ros <name>` on a ROS install, `<name>` in a venv. The long-running
# ones go through nodes/entry.py, which keeps a signal during the imports quiet (exit 0, no traceback).
CONSOLE_SCRIPTS = [
    "tracker = swir_tracker_ros.nodes.entry:tracker",
    "positioner_bridge = swir_tracker_ros.nodes.entry:positioner_bridge",
    "pelco_sim = swir_tracker_ros.nodes.entry:pelco_sim",
    "harness = swir_tracker_ros.harness.cli:main",
    "scene_camera = swir_tracker_ros.nodes.entry:scene_camera",
    "acquisition = swir_tracker_ros.nodes.entry:acquisition",
    "demo = swir_tracker_ros.demo.run:main",
]

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "benchmarks", "benchmarks.*"]),
    package_data={PACKAGE: ["py.typed", "models/*.onnx", "models/*.json"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/params", glob("params/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/config", glob("config/*.xml")),
        (f"share/{PACKAGE}/urdf", glob("urdf/*")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="swir_tracker_ros maintainers",
    maintainer_email="maintainers@swir-tracker.invalid",
    description="SWIR pan-tilt single-object tracker (KCF/DCF-CA + robust Kalman) for ROS 2 Jazzy",
    license="Apache-2.0",
    python_requires=">=3.10",
    tests_require=["pytest"],
    entry_points={"console_scripts": CONSOLE_SCRIPTS},
)
