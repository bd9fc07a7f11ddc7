# SPDX-License-Identifier: Apache-2.0
"""Pelco-D frames: encoder for the standard and extended commands, streaming decoder with resync."""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.errors import PelcoError

SYNC = 0xFF
FRAME_LEN = 7
MAX_SPEED = 0x3F
TURBO = 0xFF

# command 1 bits
SENSE = 0x80
CAMERA_ON_OFF = 0x08
IRIS_CLOSE = 0x04
IRIS_OPEN = 0x02
FOCUS_NEAR = 0x01
# command 2 bits (bit 0 = 0: standard command)
FOCUS_FAR = 0x80
ZOOM_WIDE = 0x40
ZOOM_TELE = 0x20
TILT_DOWN = 0x10
TILT_UP = 0x08
PAN_LEFT = 0x04
PAN_RIGHT = 0x02
# extended commands (command 1 = 0, command 2 odd)
SET_PRESET = 0x03
CLEAR_PRESET = 0x05
GOTO_PRESET = 0x07
SET_AUX = 0x09
CLEAR_AUX = 0x0B
REMOTE_RESET = 0x0F
ZOOM_SPEED = 0x25
FOCUS_SPEED = 0x27
SET_PAN_POSITION = 0x4B
SET_TILT_POSITION = 0x4D
SET_ZOOM_POSITION = 0x4F
QUERY_PAN = 0x51
QUERY_TILT = 0x53
QUERY_ZOOM = 0x55
PAN_POSITION_REPLY = 0x59
TILT_POSITION_REPLY = 0x5B
ZOOM_POSITION_REPLY = 0x5D
POSITION_REPLIES = (PAN_POSITION_REPLY, TILT_POSITION_REPLY, ZOOM_POSITION_REPLY)


def checksum(address: int, cmd1: int, cmd2: int, data1: int, data2: int) -> int:
    """Sum of bytes 2-6 modulo 256 (not % 100, a known bug of public implementations)."""
    return (address + cmd1 + cmd2 + data1 + data2) & 0xFF


def _byte(name: str, value: int, lo: int = 0, hi: int = 0xFF) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise PelcoError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")
    return value


@dataclass(frozen=True)
class Frame:
    """One 7-byte Pelco-D frame (sync and checksum implied)."""

    address: int
    cmd1: int
    cmd2: int
    data1: int
    data2: int

    def __post_init__(self) -> None:
        _byte("address", self.address, 1)
        for name in ("cmd1", "cmd2", "data1", "data2"):
            _byte(name, getattr(self, name))

    @property
    def checksum(self) -> int:
        return checksum(self.address, self.cmd1, self.cmd2, self.data1, self.data2)

    def to_bytes(self) -> bytes:
        return bytes((SYNC, self.address, self.cmd1, self.cmd2, self.data1, self.data2, self.checksum))

    @property
    def extended(self) -> bool:
        return bool(self.cmd2 & 0x01)

    @property
    def word(self) -> int:
        """data1:data2 as a 16-bit big-endian value (positions, replies)."""
        return (self.data1 << 8) | self.data2

    def motion(self) -> tuple[int, int, int, int] | None:
        """(pan_dir, pan_speed, tilt_dir, tilt_speed) of a standard command, dir +1 = right / up, else None.

        Pelco directions, not our sign convention: the controller maps right to negative pan.
        """
        if self.extended:
            return None
        pan = (1 if self.cmd2 & PAN_RIGHT else 0) - (1 if self.cmd2 & PAN_LEFT else 0)
        tilt = (1 if self.cmd2 & TILT_UP else 0) - (1 if self.cmd2 & TILT_DOWN else 0)
        return pan, self.data1 if pan else 0, tilt, self.data2 if tilt else 0

    @property
    def zoom(self) -> int:
        """+1 tele (in), -1 wide (out), 0 none, of a standard command (0 for an extended one)."""
        if self.extended:
            return 0
        return (1 if self.cmd2 & ZOOM_TELE else 0) - (1 if self.cmd2 & ZOOM_WIDE else 0)


def standard(address: int, cmd1: int = 0, cmd2: int = 0, data1: int = 0, data2: int = 0) -> bytes:
    if _byte("cmd2", cmd2) & 0x01:
        raise PelcoError(f"standard command 2 must have bit 0 clear, got 0x{cmd2:02X}")
    return Frame(address, cmd1, cmd2, data1, data2).to_bytes()


def extended(address: int, cmd2: int, data1: int = 0, data2: int = 0) -> bytes:
    if not _byte("cmd2", cmd2) & 0x01:
        raise PelcoError(f"extended command 2 must be odd, got 0x{cmd2:02X}")
    return Frame(address, 0, cmd2, data1, data2).to_bytes()


def stop(address: int) -> bytes:
    return standard(address)


def _speed(name: str, value: int, turbo: bool) -> int:
    if turbo and value == TURBO:
        return value
    return _byte(name, value, 0, MAX_SPEED)


def pan_tilt(address: int, pan_dir: int, pan_speed: int, tilt_dir: int, tilt_speed: int, zoom: int = 0
             ) -> bytes:
    """Pan/tilt move: dir +1 = right / up, -1 = left / down, 0 = none; pan speed 0-0x3F or 0xFF (turbo).

    `zoom` +1 tele (in), -1 wide (out), 0 none: a standard frame is the head's whole pan/tilt/lens state,
    so a zoom that should continue while the head pans travels in the same frame.
    """
    if pan_dir not in (-1, 0, 1) or tilt_dir not in (-1, 0, 1) or zoom not in (-1, 0, 1):
        raise PelcoError(f"directions must be -1, 0 or +1, got pan {pan_dir!r}, tilt {tilt_dir!r}, "
                         f"zoom {zoom!r}")
    cmd2 = {1: PAN_RIGHT, -1: PAN_LEFT, 0: 0}[pan_dir] | {1: TILT_UP, -1: TILT_DOWN, 0: 0}[tilt_dir]
    cmd2 |= {1: ZOOM_TELE, -1: ZOOM_WIDE, 0: 0}[zoom]
    d1 = _speed("pan speed", pan_speed, turbo=True) if pan_dir else 0
    d2 = _speed("tilt speed", tilt_speed, turbo=False) if tilt_dir else 0
    return standard(address, 0, cmd2, d1, d2)


def right(address: int, speed: int) -> bytes:
    return pan_tilt(address, 1, speed, 0, 0)


def left(address: int, speed: int) -> bytes:
    return pan_tilt(address, -1, speed, 0, 0)


def up(address: int, speed: int) -> bytes:
    return pan_tilt(address, 0, 0, 1, speed)


def down(address: int, speed: int) -> bytes:
    return pan_tilt(address, 0, 0, -1, speed)


def lens(address: int, *, zoom: int = 0, focus: int = 0, iris: int = 0) -> bytes:
    """Zoom (+1 tele, -1 wide), focus (+1 far, -1 near), iris (+1 open, -1 close); 0 = no action."""
    if any(v not in (-1, 0, 1) for v in (zoom, focus, iris)):
        raise PelcoError(f"zoom/focus/iris must be -1, 0 or +1, got {(zoom, focus, iris)}")
    cmd1 = {1: IRIS_OPEN, -1: IRIS_CLOSE, 0: 0}[iris] | (FOCUS_NEAR if focus < 0 else 0)
    cmd2 = {1: ZOOM_TELE, -1: ZOOM_WIDE, 0: 0}[zoom] | (FOCUS_FAR if focus > 0 else 0)
    return standard(address, cmd1, cmd2)


def camera(address: int, on: bool) -> bytes:
    """Camera on (sense bit set) / off."""
    return standard(address, (SENSE | CAMERA_ON_OFF) if on else CAMERA_ON_OFF)


def _preset(cmd2: int, address: int, preset: int) -> bytes:
    return extended(address, cmd2, 0, _byte("preset", preset, 1, 0xFF))  # preset 0 is invalid on most heads


def set_preset(address: int, preset: int) -> bytes:
    return _preset(SET_PRESET, address, preset)


def clear_preset(address: int, preset: int) -> bytes:
    return _preset(CLEAR_PRESET, address, preset)


def goto_preset(address: int, preset: int) -> bytes:
    return _preset(GOTO_PRESET, address, preset)


def aux(address: int, number: int, on: bool) -> bytes:
    return extended(address, SET_AUX if on else CLEAR_AUX, 0, _byte("auxiliary", number, 1, 8))


def _word(cmd2: int, address: int, value: int, name: str, hi: int = 0xFFFF) -> bytes:
    v = _byte(name, value, 0, hi)
    return extended(address, cmd2, v >> 8, v & 0xFF)


def set_pan_position(address: int, hundredths: int) -> bytes:
    """Absolute pan in hundredths of a degree, 0-35999."""
    return _word(SET_PAN_POSITION, address, hundredths, "pan position", 35999)


def set_tilt_position(address: int, raw: int) -> bytes:
    """Absolute tilt, raw 16-bit value (the degree convention is vendor-specific, see pelco.units)."""
    return _word(SET_TILT_POSITION, address, raw, "tilt position")


def query(address: int, what: str) -> bytes:
    cmd2 = {"pan": QUERY_PAN, "tilt": QUERY_TILT, "zoom": QUERY_ZOOM}.get(what)
    if cmd2 is None:
        raise PelcoError(f"query must be 'pan', 'tilt' or 'zoom', got {what!r}")
    return extended(address, cmd2)


def position_reply(address: int, what: str, raw: int) -> bytes:
    """The head's answer to a query: 0x59 pan / 0x5B tilt / 0x5D zoom with data1:data2 = raw."""
    cmd2 = {"pan": PAN_POSITION_REPLY, "tilt": TILT_POSITION_REPLY, "zoom": ZOOM_POSITION_REPLY}.get(what)
    if cmd2 is None:
        raise PelcoError(f"reply must be 'pan', 'tilt' or 'zoom', got {what!r}")
    return _word(cmd2, address, raw, f"{what} position")


def decode(data: bytes) -> Frame:
    """Exactly one frame; `PelcoError` on a wrong length, sync, address 0 or checksum."""
    if len(data) != FRAME_LEN:
        raise PelcoError(f"a Pelco-D frame has 7 bytes, got {len(data)}")
    if data[0] != SYNC or data[1] == 0:
        raise PelcoError(f"bad sync 0x{data[0]:02X} or address 0x{data[1]:02X}")
    if checksum(*data[1:6]) != data[6]:
        raise PelcoError(f"checksum 0x{data[6]:02X} != 0x{checksum(*data[1:6]):02X} in {data.hex(' ')}")
    return Frame(*data[1:6])


class StreamDecoder:
    """Frames from an arbitrary byte stream; never raises on data.

    Resynchronises on the next 0xFF after garbage. A 7-byte candidate with a bad checksum counts one
    `checksum_errors` and the search restarts one byte after its sync (a payload 0xFF may be the real sync);
    bytes skipped while looking for a sync are counted in `discarded`.
    """

    def __init__(self) -> None:
        self._buf = bytearray()  # never longer than one partial frame between calls
        self.frames = 0
        self.checksum_errors = 0
        self.discarded = 0

    def feed(self, data: bytes) -> list[Frame]:
        self._buf.extend(data)
        out: list[Frame] = []
        buf = self._buf
        while True:
            start = buf.find(SYNC)
            if start < 0:
                self.discarded += len(buf)
                buf.clear()
                break
            if start:
                self.discarded += start
                del buf[:start]
            if len(buf) < FRAME_LEN:
                break
            # An address of 0 cannot follow a real sync; 0xFF 0xFF may be garbage then a sync.
            if buf[1] == 0 or checksum(*buf[1:6]) != buf[6]:
                if buf[1] != 0:
                    self.checksum_errors += 1
                else:
                    self.discarded += 1
                del buf[:1]
                continue
            out.append(Frame(*buf[1:6]))
            self.frames += 1
            del buf[:FRAME_LEN]
        return out

    def reset(self) -> None:
        self._buf.clear()
