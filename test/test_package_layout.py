# SPDX-License-Identifier: Apache-2.0
"""The package is laid out as an ament_python package and imports without rclpy in the core."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from conftest import REPO


def test_package_xml_format3_and_depends() -> None:
    root = ET.parse(REPO / "package.xml").getroot()
    assert root.get("format") == "3"
    assert root.findtext("name") == "swir_tracker_ros"
    deps = {e.text for e in root.findall("exec_depend")}
    for needed in ("rclpy", "sensor_msgs", "geometry_msgs", "std_msgs", "std_srvs", "diagnostic_msgs",
                   "python3-numpy", "python3-opencv", "python3-serial"):
        assert needed in deps, needed
    assert root.find("export/build_type").text == "ament_python"


def test_resource_marker_and_setup_cfg() -> None:
    assert (REPO / "resource" / "swir_tracker_ros").is_file()
    cfg = (REPO / "setup.cfg").read_text()
    assert "install_scripts=$base/lib/swir_tracker_ros" in cfg
    assert "script_dir=$base/lib/swir_tracker_ros" in cfg
