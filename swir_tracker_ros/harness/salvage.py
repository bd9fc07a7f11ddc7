# SPDX-License-Identifier: Apache-2.0
"""Damage reports: scan a corrupt or truncated storage file message by message to find the last good one."""

from __future__ import annotations

import sqlite3
import struct
from binascii import crc32
from dataclasses import dataclass
from pathlib import Path

from lz4.frame import decompress as lz4_decompress

try:  # Python 3.14 ships compression.zstd; rosbags depends on the backport before that
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:  # pragma: no cover - depends on the interpreter
    from backports import zstd  # type: ignore[import-not-found,no-redef]

MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class Damage:
    """How far a storage file reads: good messages before the first failure, the last one, and why."""

    file: Path
    good: int
    last_topic: str | None
    last_time_ns: int | None
    reason: str

    def sentence(self) -> str:
        last = (f"#{self.good} on {self.last_topic} at {self.last_time_ns} ns" if self.good
                else "none (no message could be read)")
        return (f"{self.file}: corrupt or truncated after {self.good} good messages; "
                f"last good message: {last}; {self.reason}")


def scan(path: Path) -> Damage | None:
    """Damage of one storage file (.db3 or .mcap); None when every message reads cleanly."""
    return scan_mcap(path) if path.suffix == ".mcap" else scan_sqlite(path)


def scan_sqlite(path: Path) -> Damage | None:
    good, topic, stamp = 0, None, None
    try:
        con = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    except sqlite3.Error as exc:
        return Damage(path, 0, None, None, f"sqlite: {exc}")
    try:
        names = dict(con.execute("SELECT id, name FROM topics"))
        for tid, t, data in con.execute("SELECT topic_id, timestamp, data FROM messages ORDER BY id"):
            if tid not in names or data is None or len(data) < 4:
                return Damage(path, good, topic, stamp, f"message {good + 1} has a bad topic or payload")
            good, topic, stamp = good + 1, names[tid], int(t)
    except sqlite3.Error as exc:
        return Damage(path, good, topic, stamp, f"sqlite: {exc}")
    finally:
        con.close()
    return None


class _CutError(Exception):
    pass


def _take(buf: bytes, pos: int, n: int) -> tuple[bytes, int]:
    if pos + n > len(buf):
        raise _CutError(f"record cut short at byte {pos} (needs {n} more)")
    return buf[pos:pos + n], pos + n


def _records(buf: bytes, pos: int, end: int, partial_op: int | None = None):
    """(opcode, body) records; a cut record of `partial_op` is yielded as far as it goes, then the cut."""
    while pos < end:
        head, pos = _take(buf, pos, 9)
        op, length = head[0], struct.unpack("<Q", head[1:])[0]
        if op == partial_op and pos + length > len(buf):
            yield op, buf[pos:]
            raise _CutError(f"record cut short at byte {pos} (needs {pos + length - len(buf)} more)")
        body, pos = _take(buf, pos, length)
        yield op, body


def scan_mcap(path: Path) -> Damage | None:
    """Sequential MCAP scan (no summary needed): channels, chunks (CRC-checked) and messages in order."""
    buf = path.read_bytes()
    good, topic, stamp = 0, None, None
    channels: dict[int, str] = {}

    def on_message(body: bytes) -> None:
        nonlocal good, topic, stamp
        cid, _, log_time = struct.unpack_from("<HIQ", body)
        if cid not in channels:
            raise _CutError(f"message on unknown channel {cid}")
        good, topic, stamp = good + 1, channels[cid], log_time

    def on_channel(body: bytes) -> None:
        cid, _, n = struct.unpack_from("<HHI", body)
        channels[cid] = body[8:8 + n].decode()

    def on_schema(body: bytes) -> None:
        _, n = struct.unpack_from("<HI", body)
        body[6:6 + n].decode()
        (m,) = struct.unpack_from("<I", body, 6 + n)
        encoding = body[10 + n:10 + n + m].decode()
        (k,) = struct.unpack_from("<I", body, 10 + n + m)
        if encoding in ("ros2msg", "ros2idl", "jsonschema"):  # text definitions
            body[14 + n + m:14 + n + m + k].decode()

    if buf[:8] != MCAP_MAGIC:
        return Damage(path, 0, None, None, "not an MCAP file (bad magic)")
    try:
        for op, body in _records(buf, 8, len(buf), partial_op=0x06):
            if op == 0x03:
                on_schema(body)
            elif op == 0x04:
                on_channel(body)
            elif op == 0x05:
                on_message(body)
            elif op == 0x06:
                _, _, size, crc, n = struct.unpack_from("<QQQII", body)
                comp = body[32:32 + n].decode()
                (csize,) = struct.unpack_from("<Q", body, 32 + n)
                data = body[40 + n:40 + n + csize]
                if len(data) < csize:  # a cut chunk: uncompressed records can still be counted
                    if not comp:
                        for iop, ibody in _records(data, 0, len(data)):
                            if iop == 0x04:
                                on_channel(ibody)
                            elif iop == 0x05:
                                on_message(ibody)
                    continue
                try:
                    raw = zstd.decompress(data) if comp == "zstd" else lz4_decompress(data) if comp == "lz4" \
                        else data
                except Exception as exc:
                    raise _CutError(f"chunk does not decompress ({comp}): {exc}") from None
                if len(raw) != size or (crc and crc32(raw) != crc):
                    raise _CutError("chunk checksum or size mismatch")
                for iop, ibody in _records(raw, 0, len(raw)):
                    if iop == 0x03:
                        on_schema(ibody)
                    elif iop == 0x04:
                        on_channel(ibody)
                    elif iop == 0x05:
                        on_message(ibody)
            elif op == 0x02:  # footer (after the data end record and the summary section)
                if not buf.endswith(MCAP_MAGIC):
                    raise _CutError("footer present but the end magic is missing")
                return None
        raise _CutError("file ends without a footer (truncated)")
    except (_CutError, struct.error, UnicodeDecodeError) as exc:
        return Damage(path, good, topic, stamp, f"{type(exc).__name__}: {exc}")
