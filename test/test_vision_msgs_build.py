# SPDX-License-Identifier: Apache-2.0
"""vision_msgs 4.1.1 (issue 39): the pinned source the venv build takes, and the types it generated."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest
from conftest import REPO, SHARED

SCRIPT = REPO / "swir_tracker_interfaces" / "build_in_venv.py"
spec = importlib.util.spec_from_file_location("build_in_venv", SCRIPT)
build_in_venv = importlib.util.module_from_spec(spec)
spec.loader.exec_module(build_in_venv)
LOCAL = SHARED / "deps" / "vision_msgs-4.1.1" / "vision_msgs"


def test_the_shared_copy_is_the_pinned_release() -> None:
    assert (SHARED / "deps" / "vision_msgs-4.1.1" / "SOURCE_COMMIT").read_text().strip() == \
        build_in_venv.VISION_MSGS_COMMIT
    assert build_in_venv.vision_msgs_source(Path("/nonexistent"), LOCAL) == LOCAL


def test_a_changed_or_unreachable_source_is_refused(tmp_path: Path) -> None:
    copy = tmp_path / "vision_msgs"
    shutil.copytree(LOCAL, copy)
    changed = copy / "msg" / "Detection2D.msg"
    changed.write_text(changed.read_text() + "int32 x\n")
    with pytest.raises(build_in_venv.SourceError, match=r"not release 4\.1\.1"):
        build_in_venv.vision_msgs_source(tmp_path / "build", copy)
    with pytest.raises(build_in_venv.SourceError, match="unreachable"):
        build_in_venv.vision_msgs_source(tmp_path / "build", tmp_path / "none", "http://127.0.0.1:9/x.tar.gz")


def test_the_venv_holds_the_generated_types() -> None:
    from vision_msgs.msg import Detection2DArray

    prefix = Path(sys.prefix)
    assert "<version>4.1.1</version>" in (prefix / "share" / "vision_msgs" / "package.xml").read_text()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "vision_msgs").is_file()
    assert Detection2DArray.__module__.startswith("vision_msgs.msg")
