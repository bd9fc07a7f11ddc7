# SPDX-License-Identifier: Apache-2.0
"""`pelco_sim` as a separate process: pty and TCP transports, dynamics, replies, faults, reconnection."""

from __future__ import annotations

import csv
import math
import signal
import time
from pathlib import Path

import pytest
import serial
from conftest import wait_for

from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.link import SerialLink
from swir_tracker_ros.pelco.speed_table import SpeedTable
from swir_tracker_ros.pelco.units import raw_to_angle


def start_sim(processes, tmp_path: Path, *args: str):
    """Start pelco_sim with a trace; return (process, port URL for pyserial, trace path)."""
    trace = tmp_path / f"trace{len(processes.procs)}.csv"
    proc = processes.start("pelco_sim", "--trace", str(trace), *args)
    first: list[str] = []

    def ready() -> bool:
        lines = processes.log(proc).splitlines()
        if lines:
            first[:] = lines[:1]
        return bool(lines) or proc.poll() is not None

    assert wait_for(ready, 15.0), "pelco_sim printed nothing"
    kind, where = first[0].split()
    assert kind in ("PTY", "TCP"), first[0]
    return proc, (where if kind == "PTY" else f"socket://{where}"), trace


def read_trace(path: Path) -> list[dict[str, float]]:
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    return [{k: float(v) for k, v in r.items()} for r in rows[:-1] if None not in r.values()]


def query(port: serial.SerialBase, what: str) -> codec.Frame:
    port.reset_input_buffer()
    port.write(codec.query(1, what))
    dec = codec.StreamDecoder()
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        for f in dec.feed(port.read(7)):
            if f.cmd2 in codec.POSITION_REPLIES:
                return f
    raise AssertionError(f"no reply to the {what} query")


def test_pty_head_moves_at_the_table_speed_and_answers_queries(processes, tmp_path) -> None:
    proc, url, trace = start_sim(processes, tmp_path, "--initial-tilt", "5")
    assert url.startswith("/dev/pts/")
    with serial.serial_for_url(url, baudrate=9600, timeout=0.1) as port:
        port.write(codec.pan_tilt(1, -1, 32, -1, 16))  # left at byte 32, down at byte 16
        time.sleep(0.8)
        pan = query(port, "pan")
        tilt = query(port, "tilt")
        port.write(codec.stop(1))
        time.sleep(0.3)
    processes.stop(proc)
    rows = read_trace(trace)
    table = SpeedTable()
    moving = [r for r in rows if abs(r["pan_velocity"]) > 0.99 * math.radians(table.speed(32))]
    assert moving, "the head never reached the table speed"
    assert max(r["pan_velocity"] for r in rows) == pytest.approx(math.radians(table.speed(32)), abs=2e-6)
    assert min(r["tilt_velocity"] for r in rows) == pytest.approx(-math.radians(table.speed(16)), abs=2e-6)
    assert rows[-1]["pan_velocity"] == 0.0  # stopped
    # replies use the simulated vendor convention: pan word grows to the right, tilt word grows downwards
    pan_angle, tilt_angle = raw_to_angle(pan.word, -1, 0.0), raw_to_angle(tilt.word, -1, 0.0)
    assert 0.0 < pan_angle < rows[-1]["pan"] + 1e-4
    assert rows[-1]["tilt"] - 1e-4 < tilt_angle < math.radians(5.0)


def test_tcp_disconnect_and_reconnect_with_serial_link(processes, tmp_path) -> None:
    proc, url, trace = start_sim(processes, tmp_path, "--tcp", "0", "--disconnect-for", "0.8",
                                 "--command-timeout", "0.3")
    logs: list[tuple[str, str]] = []
    link = SerialLink(url, log=lambda lvl, txt: logs.append((lvl, txt)), backoff_min=0.05, backoff_max=0.2)
    assert wait_for(lambda: link.poll() or link.connected, 5.0)
    assert link.write(codec.left(1, 40))
    time.sleep(0.3)
    proc.send_signal(signal.SIGUSR1)  # the simulator closes its port for 0.8 s
    assert wait_for(lambda: "EVENT disconnected" in processes.log(proc), 5.0)

    def lost() -> bool:
        link.write(codec.left(1, 40))
        link.read()
        return not link.connected

    assert wait_for(lost, 5.0)
    assert wait_for(lambda: link.poll() or link.connected, 10.0)  # back after the outage
    assert link.write(codec.stop(1))
    link.close()
    assert [lvl for lvl, _ in logs].count("warn") == 1  # one warning per outage, however many retries
    time.sleep(0.2)
    processes.stop(proc)
    rows = read_trace(trace)
    offline = [r for r in rows if r["connected"] == 0.0]
    assert offline, "no disconnected rows in the trace"
    # the head's own command timeout (0.3 s) stopped it while the port was closed
    assert offline[-1]["pan_velocity"] == 0.0 and max(r["pan_velocity"] for r in rows) > 0.0


def test_corrupted_bytes_are_counted_not_fatal(processes, tmp_path) -> None:
    proc, url, _ = start_sim(processes, tmp_path, "--corrupt", "0.05", "--seed", "3")
    link = SerialLink(url, backoff_min=0.05)
    assert wait_for(lambda: link.poll() or link.connected, 5.0)
    dec = codec.StreamDecoder()
    replies = 0
    for _ in range(60):
        link.write(codec.query(1, "pan"))
        time.sleep(0.01)
        replies += sum(f.cmd2 == codec.PAN_POSITION_REPLY for f in dec.feed(link.read()))
    time.sleep(0.1)
    replies += sum(f.cmd2 == codec.PAN_POSITION_REPLY for f in dec.feed(link.read()))
    link.close()
    assert processes.stop(proc) == 0
    stats = dict(kv.split("=") for kv in processes.log(proc).splitlines()[-1].split()[1:])
    assert int(stats["checksum_errors"]) > 0 and int(stats["corrupted"]) > 0  # head side
    assert dec.checksum_errors + dec.discarded > 0  # client side
    assert 10 < replies < 60


def test_sim_rejects_a_bad_speed_table(processes, tmp_path) -> None:
    proc = processes.start("pelco_sim", "--speed-table", "8:1,4:2")
    proc.wait(15)
    assert proc.returncode == 2 and "increase" in processes.log(proc)


def test_sim_does_not_import_rclpy() -> None:
    import subprocess
    import sys
    code = "import sys, swir_tracker_ros.simulation.pelco_sim as s; assert 'rclpy' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def _settle(head, seconds: float, t0: float = 0.0) -> float:
    t = t0
    for _ in range(int(seconds / 0.005)):
        t += 0.005
        head.advance(0.005, t)
    return t


def test_head_model_positions_presets_stops_and_addresses() -> None:
    from swir_tracker_ros.pelco.head import HeadConfig, HeadModel
    from swir_tracker_ros.pelco.units import angle_to_raw

    head = HeadModel(HeadConfig(address=3, tilt_min=-20.0, tilt_max=45.0, command_timeout=0.5))
    # absolute pan position 30 deg left, in the vendor word (grows to the right)
    head.apply(codec.decode(codec.set_pan_position(3, angle_to_raw(math.radians(30.0), -1, 0.0))), 0.0)
    t = _settle(head, 2.0)
    assert head.pan.angle == pytest.approx(30.0, abs=0.01) and head.pan.velocity == 0.0
    head.apply(codec.decode(codec.set_preset(3, 7)), t)
    head.apply(codec.decode(codec.set_pan_position(3, 0)), t)
    t = _settle(head, 2.0, t)
    assert head.pan.angle == pytest.approx(0.0, abs=0.01)
    head.apply(codec.decode(codec.goto_preset(3, 7)), t)
    t = _settle(head, 2.0, t)
    assert head.pan.angle == pytest.approx(30.0, abs=0.01)
    # frames for another address are ignored
    head.apply(codec.decode(codec.up(1, 63)), t)
    t = _settle(head, 0.2, t)
    assert head.tilt.velocity == 0.0 and head.ignored == 1
    # tilt end stop, then the head's command timeout stops it
    head.apply(codec.decode(codec.up(3, 63)), t)
    t2 = _settle(head, 0.3, t)
    assert head.tilt.velocity > 0.0
    head.apply(codec.decode(codec.up(3, 63)), t2)
    t2 = _settle(head, 2.0, t2)
    assert head.tilt.angle <= 45.0 and head.tilt.velocity == 0.0
    reply = codec.decode(head.apply(codec.decode(codec.query(3, "tilt")), t2))
    assert reply.cmd2 == codec.TILT_POSITION_REPLY and reply.word == 36000 - round(head.tilt.angle * 100)
    # no valid frame for command_timeout (0.5 s): the head stops by itself
    head.apply(codec.decode(codec.left(3, 40)), t2)
    t3 = _settle(head, 0.4, t2)
    assert head.pan.velocity > 0.0
    _settle(head, 0.4, t3)
    assert head.pan.velocity == 0.0
