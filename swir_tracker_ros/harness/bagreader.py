# SPDX-License-Identifier: Apache-2.0
"""`BagReader`: opens a rosbag2 bag (a directory or one .db3 / .mcap file) and streams its raw messages,
every failure a HarnessError that names the damaged file and its last good message (harness/bagio.py reads
and writes frames with it)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Reader

from msg_adapters import bag as mb
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.salvage import scan

try:  # Python 3.14 ships compression.zstd; rosbags depends on the backport before that
    from compression import zstd  # type: ignore[import-not-found]
except ImportError:  # pragma: no cover - depends on the interpreter
    from backports import zstd  # type: ignore[import-not-found,no-redef]


class BagReader:
    """Opens a bag (directory or single .db3/.mcap file) and streams raw messages with a count cross-check.

    When metadata.yaml declares a connection that no storage connection matches (rosbags compares the QoS
    text too; ROS 2's own test bags differ there), the storage files are read directly instead, so a QoS
    mismatch never yields zero messages.
    """

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise HarnessError(f"{self.path}: no such bag")
        _check_readable(self.path)
        self.notes: list[str] = []
        self.read_mode = "directory" if self.path.is_dir() else "storage file"
        self.files: list[Path] = [self.path]
        reader = self._open(self.path)
        try:
            self.storage = self._storage_id(reader)
            self.version = _metadata_version(self.path)
            self.compression = reader.compression_format if reader.compression_mode else None
            self.compression_mode = reader.compression_mode
            mcaps = [f for f in self._storage_files(reader) if f.suffix == ".mcap" and f.is_file()]
            if self.compression is None and mcaps and (chunk := mcap_chunk_compression(mcaps[0])):
                self.compression = f"{chunk} (mcap chunks)"
            meta = getattr(reader.storage, "metadata", None)
            self.custom = dict((meta.custom if meta is not None else None) or {})
            self.start_ns, self.end_ns = reader.start_time, reader.end_time
            self.connections = [(c.topic, c.msgtype, c.msgcount) for c in reader.connections]
            if self.path.is_dir():
                self.files = self._storage_files(reader)
                unmatched = _unmatched(reader)
                if unmatched:
                    self.read_mode = "storage files"
                    self.notes.append(f"metadata connections {sorted(unmatched)} differ from the storage "
                                      "(QoS text); reading the storage files directly")
        finally:
            reader.close()

    def _storage_files(self, reader: Reader) -> list[Path]:
        if not self.path.is_dir():
            return [self.path]
        return [self.path / Path(f).name for f in _metadata(self.path).get("relative_file_paths", [])]

    def _open(self, path: Path) -> Reader:
        try:
            reader = Reader(path)
            reader.open()
        except Exception as exc:  # rosbags, sqlite3, mcap and zstd raise many types for one cause
            raise HarnessError(self._damage(path, f"cannot open the bag: {type(exc).__name__}: {exc}")) \
                from None
        return reader

    def _damage(self, path: Path, what: str) -> str:
        """`what` went wrong in `path`: add which storage file is damaged and its last good message."""
        files = [path] if path.is_file() else sorted(
            f for f in path.iterdir() if f.suffix in (".db3", ".mcap")) if path.is_dir() else []
        for f in files:
            if not f.is_file():
                continue
            d = scan(f)
            if d is not None:
                return f"{d.sentence()} ({what})"
        return f"{path}: {what}"

    @staticmethod
    def _storage_id(reader: Reader) -> str:
        name = type(reader.storage).__name__.lower()
        if "directory" in name:
            return str(_metadata(reader.path).get("storage_identifier", "?"))
        return "mcap" if "mcap" in name else "sqlite3"

    def topics(self) -> dict[str, str]:
        return {t: m for t, m, _ in self.connections}

    def declared(self) -> dict[str, int | None]:
        out: dict[str, int | None] = {}
        for t, _, n in self.connections:
            out[t] = (out.get(t) or 0) + n if n is not None else out.get(t)
        return out

    def messages(self, topics: set[str] | None = None) -> Iterator[tuple[str, str, int, bytes]]:
        """(topic, msgtype, log time ns, raw CDR) in storage order; HarnessError on a corrupt bag."""
        sources = self.files if self.read_mode == "storage files" else [self.path]
        last = "none (the first message could not be read)"
        count = 0
        for src in sources:
            if self.read_mode == "storage files" and self.compression_mode == "file":
                raise HarnessError(f"{src}: file-compressed storage cannot be read directly")
            reader = self._open(src)
            try:
                conns = [c for c in reader.connections if topics is None or c.topic in topics]
                it = reader.messages(connections=conns) if conns else iter(())
                while True:
                    try:
                        conn, t, raw = next(it)
                    except StopIteration:
                        break
                    except Exception as exc:
                        why = f"{type(exc).__name__}: {exc}"
                        raise HarnessError(self._damage(src, f"reading stopped after {count} good messages "
                                                        f"(last good message: {last}): {why}")) from None
                    if self.read_mode == "storage files" and self.compression_mode == "message":
                        raw = zstd.decompress(raw)
                    yield conn.topic, conn.msgtype, t, raw
                    count += 1
                    last = f"#{count} {conn.topic} at {t} ns"
            finally:
                reader.close()

    def deserialize(self, raw: bytes, msgtype: str, where: str) -> Any:
        try:
            return mb.deserialize(raw, msgtype)
        except Exception as exc:
            why = f"{type(exc).__name__}: {exc}"
            raise HarnessError(f"{self.path}: {where}: cannot decode {msgtype}: {why}") from None


def mcap_chunk_compression(path: Path) -> str | None:
    """Compression of the first chunk of an MCAP file ('zstd', 'lz4'; None: no chunk or uncompressed)."""
    import struct

    with path.open("rb") as fh:
        if fh.read(8) != b"\x89MCAP0\r\n":
            return None
        while True:
            head = fh.read(9)
            if len(head) < 9:
                return None
            op, length = head[0], struct.unpack("<Q", head[1:])[0]
            if op == 0x06:  # Chunk: start u64, end u64, size u64, crc u32, compression string
                body = fh.read(min(length, 32 + 4 + 64))
                n = struct.unpack_from("<I", body, 28)[0]
                return body[32:32 + n].decode(errors="replace") or None
            if op in (0x02, 0x0F):  # footer or data end: no chunk in the data section
                return None
            fh.seek(length, 1)


def _regular(path: Path) -> None:
    """HarnessError for a path that opening would block on or that is no file: a FIFO named x.db3 or
    x.mcap, a socket, a device (opening a FIFO waits for a writer forever)."""
    if path.exists() and not path.is_file() and not path.is_dir():
        raise HarnessError(f"{path}: not a regular file (a FIFO, socket or device); a bag is a directory "
                           "with metadata.yaml or a single .db3 / .mcap file")


def _check_readable(path: Path) -> None:
    """Before rosbags opens `path`: no FIFO anywhere it would read, and a directory has its metadata.yaml
    (reported by that file's name, with the way to rebuild it)."""
    _regular(path)
    if not path.is_dir():
        return
    meta = path / "metadata.yaml"
    if not meta.exists():
        storage = sorted(f.name for f in path.iterdir() if f.suffix in (".db3", ".mcap"))
        hint = (f"; `ros2 bag reindex {path}` rebuilds it from {', '.join(storage)}" if storage
                else "; the directory holds no .db3 / .mcap storage file either")
        raise HarnessError(f"{meta}: no such file (a rosbag2 directory needs it){hint}")
    _regular(meta)
    for f in path.iterdir():
        _regular(f)


def _metadata(path: Path) -> dict[str, Any]:
    meta = path / "metadata.yaml"
    if not meta.exists():
        return {}
    _regular(meta)
    from ruamel.yaml import YAML

    try:
        return YAML(typ="safe").load(meta.read_text()).get("rosbag2_bagfile_information", {})
    except Exception as exc:
        raise HarnessError(f"{meta}: unreadable metadata: {exc}") from None


def _metadata_version(path: Path) -> int | None:
    v = _metadata(path).get("version") if path.is_dir() else None
    return int(v) if v is not None else None


def _unmatched(reader: Reader) -> set[str]:
    """Metadata connections that no storage connection matches the way rosbags' DirectoryReader matches."""
    storages = getattr(reader.storage, "storages", [])
    out = set()
    for c in reader.connections:
        if not any(x.topic == c.topic and x.msgtype == c.msgtype and x.ext == c.ext
                   and (not x.digest or not c.digest or x.digest == c.digest)
                   for s in storages for x in s.connections):
            out.add(c.topic)
    return out
