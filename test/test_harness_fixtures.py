# SPDX-License-Identifier: Apache-2.0
"""Real rosbag2 bags recorded by ROS 2's own tools: counts as declared and as read, dirs and single files."""

from __future__ import annotations

import pytest

from swir_tracker_ros.harness import cli
from swir_tracker_ros.harness.bagio import bag_info
from swir_tracker_ros.harness.bagreader import BagReader

# Per-topic counts stated in each fixture's metadata.yaml (wbag: summed over its five split files).
EXPECTED = {
    "talker": {"/topic": 10, "/rosout": 10, "/parameter_events": 0},
    "cdr_test": {"/array_topic": 4, "/test_topic": 3},
    "wbag": {"AAA": 804, "BBB": 742, "CCC": 742, "DDD": 753, "EEE": 804, "FFF": 772, "GGG": 731, "HHH": 726},
}


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_directory_counts_declared_equal_read(shared_dir, storage, name):
    bag = shared_dir / "data/rosbag2_fixtures" / storage / name
    info = bag_info(bag)
    assert info.storage == storage
    got = {t.topic: (t.declared, t.read) for t in info.topics}
    assert got == {t: (n, n) for t, n in EXPECTED[name].items()}
    assert info.version in (4, 7) and info.duration_s > 0


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_talker_qos_mismatch_does_not_yield_zero(shared_dir, storage):
    """metadata.yaml (version 4) QoS text differs from the storage's: rosbags alone reads 0 messages."""
    from rosbags.rosbag2 import Reader

    bag = shared_dir / "data/rosbag2_fixtures" / storage / "talker"
    with Reader(bag) as plain:
        assert sum(1 for _ in plain.messages()) == 0  # the pitfall this harness guards against
    br = BagReader(bag)
    assert br.read_mode == "storage files" and any("QoS" in n for n in br.notes)
    assert sum(1 for _ in br.messages()) == 20


@pytest.mark.parametrize("storage,suffix", [("sqlite3", ".db3"), ("mcap", ".mcap")])
def test_single_storage_files(shared_dir, storage, suffix):
    files = sorted((shared_dir / "data/rosbag2_fixtures" / storage / "wbag").glob(f"*{suffix}"))
    assert len(files) == 5
    total = 0
    for f in files:
        info = bag_info(f)
        assert info.read_mode == "storage file" and info.version is None
        assert all(t.declared == t.read for t in info.topics)
        total += sum(t.read for t in info.topics)
    assert total == sum(EXPECTED["wbag"].values())


def test_info_command_prints_both_counts(shared_dir, capsys):
    assert cli.main(["info", str(shared_dir / "data/rosbag2_fixtures/mcap/talker")]) == 0
    out = capsys.readouterr().out
    assert "Storage id:        mcap" in out and "Metadata version:  4" in out
    assert "Topic: /topic | Type: std_msgs/msg/String | Count: declared 10, read 10" in out
    assert "zstd (mcap chunks)" in out and "QoS" in out
