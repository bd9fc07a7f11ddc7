# SPDX-License-Identifier: Apache-2.0
"""`pelco_sim`: a simulated Pelco-D pan-tilt head on a pty or loopback TCP port, with fault injection."""

from __future__ import annotations

import argparse
import csv
import math
import random
import select
import signal
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from swir_tracker_ros.errors import PelcoError
from swir_tracker_ros.pelco import codec
from swir_tracker_ros.pelco.head import HeadConfig, HeadModel
from swir_tracker_ros.pelco.speed_table import DEFAULT_TURBO_DPS, SpeedTable, parse_table
from swir_tracker_ros.pelco.transport import PtyTransport, TcpTransport

TRACE_COLUMNS = ("time", "pan", "tilt", "pan_velocity", "tilt_velocity", "connected", "frames",
                 "checksum_errors")


class Faults:
    """Per-byte drop / bit-flip probabilities and a fixed latency, applied to both directions."""

    def __init__(self, drop: float, corrupt: float, latency: float, seed: int) -> None:
        self.drop, self.corrupt, self.latency = drop, corrupt, latency
        self.rng = random.Random(seed)
        self.dropped = self.corrupted = 0

    def mangle(self, data: bytes) -> bytes:
        if self.drop <= 0.0 and self.corrupt <= 0.0:
            return data
        out = bytearray()
        for b in data:
            if self.rng.random() < self.drop:
                self.dropped += 1
                continue
            if self.rng.random() < self.corrupt:
                b ^= 1 << self.rng.randrange(8)
                self.corrupted += 1
            out.append(b)
        return bytes(out)


class Simulator:
    """Event loop: transport I/O, decoding, delayed command effects and replies, physics, trace."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        xs, pan_dps = parse_table(args.speed_table)
        _, tilt_dps = parse_table(args.tilt_speed_table or args.speed_table)
        cfg = HeadConfig(
            address=args.address, pan_table=SpeedTable(xs, pan_dps, args.turbo_speed),
            tilt_table=SpeedTable(xs, tilt_dps, max(tilt_dps[-1], 0.0)), max_accel=args.max_accel,
            tilt_min=args.tilt_min, tilt_max=args.tilt_max, command_timeout=args.command_timeout,
            zoom_time=args.zoom_time,
        )
        self.head = HeadModel(cfg, args.initial_pan, args.initial_tilt)
        self.transport = TcpTransport(args.tcp) if args.tcp is not None else PtyTransport(args.link)
        self.faults = Faults(args.drop, args.corrupt, args.latency, args.seed)
        self.decoder = codec.StreamDecoder()
        self.inbound: list[tuple[float, codec.Frame]] = []
        self.outbound: list[tuple[float, bytes]] = []
        self.connected = False
        self.reconnect_at = math.inf
        self.disconnects = sorted(args.disconnect_at)
        self.running = True
        self.disconnect_requested = False
        self.frame_log = open(args.frame_log, "w") if args.frame_log else None  # noqa: SIM115
        self.wire_log = open(args.wire_log, "w") if args.wire_log else None  # noqa: SIM115

    def _on_signal(self, signum: int, _frame) -> None:
        if signum == signal.SIGUSR1:
            self.disconnect_requested = True
        else:
            self.running = False
            # A second SIGINT (terminal Ctrl-C plus `ros2 launch`) must not kill the interpreter while it
            # finalises (Python restores the default handlers then): exit 0 either way.
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)

    def _event(self, text: str) -> None:
        print(f"EVENT {text} {time.time():.3f}", flush=True)

    def _disconnect(self, now: float) -> None:
        self.transport.close()
        self.decoder.reset()
        self.inbound.clear()
        self.outbound.clear()
        self.connected = False
        self.reconnect_at = now + self.args.disconnect_for
        self._event("disconnected")

    def run(self) -> int:
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1):
            signal.signal(sig, self._on_signal)
        try:
            print(self.transport.open(), flush=True)
        except OSError as exc:
            print(f"pelco_sim: cannot open the port: {exc}", file=sys.stderr)
            return 2
        self.connected = True
        t0 = last = time.monotonic()
        next_trace = t0
        trace_fh = open(self.args.trace, "w", newline="") if self.args.trace else None  # noqa: SIM115
        writer = csv.writer(trace_fh) if trace_fh else None
        if writer:
            writer.writerow(TRACE_COLUMNS)
        tick = 1.0 / self.args.rate
        try:
            while self.running:
                now = time.monotonic()
                if self.args.duration and now - t0 >= self.args.duration:
                    break
                if self.connected and (self.disconnect_requested or (self.disconnects and
                                       now - t0 >= self.disconnects[0])):
                    if not self.disconnect_requested:
                        self.disconnects.pop(0)
                    self.disconnect_requested = False
                    self._disconnect(now)
                if not self.connected and now >= self.reconnect_at:
                    self.transport.open()
                    self.connected, self.reconnect_at = True, math.inf
                    self._event("connected")
                self._io(now, tick)
                now = time.monotonic()
                self.head.advance(now - last, now)
                last = now
                if writer and now >= next_trace:
                    next_trace = max(next_trace + self.args.trace_period, now)
                    self._trace(writer, trace_fh)
        finally:
            self.transport.close()
            if trace_fh:
                self._trace(writer, trace_fh)
                trace_fh.close()
            for fh in (self.frame_log, self.wire_log):
                if fh is not None:
                    fh.close()
            print(f"STATS frames={self.head.frames} checksum_errors={self.decoder.checksum_errors} "
                  f"discarded={self.decoder.discarded} dropped={self.faults.dropped} "
                  f"corrupted={self.faults.corrupted}", flush=True)
        return 0

    def _io(self, now: float, tick: float) -> None:
        fds = self.transport.fds() if self.connected else []
        try:
            ready, _, _ = select.select(fds, [], [], tick)
        except InterruptedError:
            ready = []
        now = time.monotonic()
        for fd in ready:
            raw = self.transport.readable(fd)
            if raw and self.wire_log is not None:
                self.wire_log.write(f"{time.time():.4f} {raw.hex()}\n")
                self.wire_log.flush()
            data = self.faults.mangle(raw)
            for frame in self.decoder.feed(data):
                self.inbound.append((now + self.faults.latency, frame))
                if self.frame_log is not None:
                    f = frame
                    self.frame_log.write(f"{time.time():.4f} {f.address} {f.cmd1:02x} {f.cmd2:02x} "
                                         f"{f.data1:02x} {f.data2:02x}\n")
                    self.frame_log.flush()
        while self.inbound and self.inbound[0][0] <= now:
            _, frame = self.inbound.pop(0)
            reply = self.head.apply(frame, now)
            if reply:
                self.outbound.append((now + self.faults.latency, reply))
        while self.outbound and self.outbound[0][0] <= now:
            _, data = self.outbound.pop(0)
            self.transport.write(self.faults.mangle(data))

    def _trace(self, writer, fh) -> None:
        h = self.head
        writer.writerow((f"{time.time():.4f}", f"{math.radians(h.pan.angle):.6f}",
                         f"{math.radians(h.tilt.angle):.6f}", f"{math.radians(h.pan.velocity):.6f}",
                         f"{math.radians(h.tilt.velocity):.6f}", int(self.connected), h.frames,
                         self.decoder.checksum_errors))
        fh.flush()


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def build_parser() -> argparse.ArgumentParser:
    default_table = ",".join(f"{b:g}:{v:g}" for b, v in zip(SpeedTable().bytes_, SpeedTable().dps))
    ap = argparse.ArgumentParser(
        prog="pelco_sim", description="Simulated Pelco-D pan-tilt head. The first stdout line is "
        "'PTY <path>' or 'TCP 127.0.0.1:<port>'; later lines are 'EVENT connected|disconnected <unix time>' "
        "and a final 'STATS ...'. SIGUSR1 closes the port for --disconnect-for seconds.")
    ap.add_argument("--tcp", type=int, default=None, metavar="PORT",
                    help="serve TCP on 127.0.0.1:PORT (0 = any free port) instead of a pty")
    ap.add_argument("--link", default=None, help="keep a symlink to the current pty slave at this path")
    ap.add_argument("--address", type=int, default=1, help="Pelco-D address of the head (default 1)")
    ap.add_argument("--speed-table", default=default_table,
                    help="pan (and tilt) speed table 'byte:deg_s,...'")
    ap.add_argument("--tilt-speed-table", default=None, help="tilt table if different from pan")
    ap.add_argument("--turbo-speed", type=float, default=DEFAULT_TURBO_DPS, help="pan turbo deg/s")
    ap.add_argument("--max-accel", type=float, default=120.0, help="acceleration limit, deg/s^2")
    ap.add_argument("--initial-pan", type=float, default=0.0, help="deg, + = left (CCW from above)")
    ap.add_argument("--initial-tilt", type=float, default=0.0, help="deg, + = up")
    ap.add_argument("--tilt-min", type=float, default=-90.0, help="mechanical end stop, deg")
    ap.add_argument("--tilt-max", type=float, default=90.0, help="mechanical end stop, deg")
    ap.add_argument("--command-timeout", type=float, default=0.0,
                    help="stop if no valid frame for this long, s (0 = never, like most heads)")
    ap.add_argument("--drop", type=float, default=0.0, help="per-byte drop probability (both directions)")
    ap.add_argument("--corrupt", type=float, default=0.0,
                    help="per-byte bit-flip probability (both directions)")
    ap.add_argument("--latency", type=float, default=0.0, help="delay of command effects and replies, s")
    ap.add_argument("--disconnect-at", type=_floats, default=[], help="close the port at these times, s")
    ap.add_argument("--disconnect-for", type=float, default=2.0, help="how long the port stays closed, s")
    ap.add_argument("--seed", type=int, default=0, help="fault injection seed")
    ap.add_argument("--rate", type=float, default=200.0, help="physics rate, Hz")
    ap.add_argument("--trace", type=Path, default=None,
                    help=f"write true pose CSV ({', '.join(TRACE_COLUMNS)}; "
                    "rad, rad/s, our sign convention, unix time)")
    ap.add_argument("--frame-log", type=Path, default=None,
                    help="append every valid frame received: '<unix time> <address> <cmd1> <cmd2> <data1> "
                    "<data2>' (hex bytes), flushed per frame")
    ap.add_argument("--wire-log", type=Path, default=None,
                    help="append every chunk of bytes read from the line, valid or not: '<unix time> <hex>', "
                    "flushed per chunk (what the controller put on the bus)")
    ap.add_argument("--zoom-time", type=float, default=4.0,
                    help="s from full wide to full tele (zoom position words 0-65535)")
    ap.add_argument("--trace-period", type=float, default=0.02, help="trace row period, s")
    ap.add_argument("--duration", type=float, default=0.0,
                    help="exit after this long, s (0 = run until killed)")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        sim = Simulator(args)
    except (PelcoError, ValueError) as exc:
        print(f"pelco_sim: {exc}", file=sys.stderr)
        return 2
    return sim.run()


if __name__ == "__main__":
    sys.exit(main())
