# SPDX-License-Identifier: Apache-2.0
"""A pyserial URL link that survives a vanishing port: log once, retry with backoff, never raise."""

from __future__ import annotations

import contextlib
import importlib.util
import re
import time
from collections.abc import Callable
from urllib.parse import parse_qs, urlsplit

import serial

from swir_tracker_ros.errors import PelcoError

Log = Callable[[str, str], None]  # (level: "info" | "warn", text)


def no_log(level: str, text: str) -> None:
    """Default logger: drop messages (nodes pass their own)."""


_SCHEME = re.compile(r"^[a-z][a-z0-9_]*$")
_NETWORK = ("socket", "rfc2217")
_LOGGING = ("debug", "info", "warning", "error")


def check_url(url: str) -> None:
    """`PelcoError` for a port that can never be opened, so that the bridge refuses it at start instead
    of retrying forever: an empty name, a URL type pyserial does not know (`bogus://x`), a network URL
    without a host or with a port outside 1-65535 (`socket://127.0.0.1:99999`), an unknown socket:// or
    loop:// option. A device path is accepted even when absent: USB adapters come and go.
    """
    if not url.strip():
        raise PelcoError("port is empty; give a device path or a pyserial URL such as socket://host:port")
    if "://" not in url:
        return
    scheme = url.split("://", 1)[0].lower()
    known = bool(_SCHEME.match(scheme)) and importlib.util.find_spec(
        f"serial.urlhandler.protocol_{scheme}") is not None
    if not known:
        raise PelcoError(f"port {url!r} can never be opened: pyserial knows no {scheme!r}:// URLs "
                         "(use a device path, socket://, rfc2217://, loop://, spy://, hwgrep://)")
    parts = urlsplit(url)
    if scheme in ("socket", "loop"):  # pyserial's own message for these is garbled ('debug|info|...')
        for option, values in parse_qs(parts.query, keep_blank_values=True).items():
            if option != "logging" or any(v not in _LOGGING for v in values):
                raise PelcoError(f"port {url!r} can never be opened: {scheme}:// takes only "
                                 f"?logging={'|'.join(_LOGGING)}, got {option}={values}")
    if scheme not in _NETWORK:
        return
    try:
        port = parts.port
    except ValueError as exc:
        raise PelcoError(f"port {url!r} can never be opened: {exc}") from None
    if not parts.hostname or port is None or not 1 <= port <= 65535:
        raise PelcoError(f"port {url!r} can never be opened: expected {scheme}://<host>:<port 1-65535>")


class SerialLink:
    """`serial.serial_for_url` with reconnection.

    `poll(now)` (re)opens the port when a retry is due and returns True on the call that connected;
    `write` and `read` return False / b"" instead of raising and mark the link down on any error.
    A failure is logged once per outage; the retry delay doubles from `backoff_min` to `backoff_max`.
    A URL that can never be opened raises `PelcoError` here (`check_url`) instead.
    """

    def __init__(self, url: str, baudrate: int = 9600, *, log: Log = no_log, backoff_min: float = 0.2,
                 backoff_max: float = 5.0, write_timeout: float = 0.2,
                 clock: Callable[[], float] = time.monotonic) -> None:
        check_url(url)
        self.url, self.baudrate = url, baudrate
        self.log, self.clock = log, clock
        self.backoff_min, self.backoff_max, self.write_timeout = backoff_min, backoff_max, write_timeout
        self._port: serial.SerialBase | None = None
        self._delay = backoff_min
        self._next_try = -float("inf")
        self._outage_logged = False
        self.connects = 0
        self.failures = 0
        self.bytes_written = 0
        self.bytes_read = 0

    @property
    def connected(self) -> bool:
        return self._port is not None

    def poll(self, now: float | None = None) -> bool:
        """Try to open the port if it is down and a retry is due; True when this call connected."""
        if self._port is not None:
            return False
        now = self.clock() if now is None else now
        if now < self._next_try:
            return False
        try:
            port = serial.serial_for_url(self.url, baudrate=self.baudrate, bytesize=serial.EIGHTBITS,
                                         parity=serial.PARITY_NONE, stopbits=serial.STOPBITS_ONE, timeout=0,
                                         write_timeout=self.write_timeout)
        except Exception as exc:
            self._fail(now, f"cannot open {self.url}: {exc}")
            return False
        self._port = port
        self._delay = self.backoff_min
        self.connects += 1
        self.log("info", f"connected to {self.url} at {self.baudrate} baud" +
                 (" (after an outage)" if self._outage_logged else ""))
        self._outage_logged = False
        return True

    def _fail(self, now: float, text: str) -> None:
        self.failures += 1
        if not self._outage_logged:
            self.log("warn", f"{text}; retrying every {self.backoff_min:g}-{self.backoff_max:g} s, head "
                     "commands are not delivered meanwhile")
            self._outage_logged = True
        self._next_try = now + self._delay
        self._delay = min(self._delay * 2.0, self.backoff_max)

    def _drop(self, text: str) -> None:
        port, self._port = self._port, None
        try:
            if port is not None:
                port.close()
        except Exception:
            pass
        self._delay = self.backoff_min
        self._fail(self.clock(), text)

    def write(self, data: bytes) -> bool:
        """Write all of data; False (and the link down) on any error or while disconnected."""
        if self._port is None:
            return False
        try:
            n = self._port.write(data)
        except Exception as exc:
            self._drop(f"lost {self.url} on write: {exc}")
            return False
        self.bytes_written += len(data) if n is None else n
        return True

    def read(self, size: int = 4096) -> bytes:
        """Whatever is waiting (non-blocking); b"" while disconnected or on error."""
        if self._port is None:
            return b""
        try:
            data = self._port.read(size)
        except Exception as exc:
            self._drop(f"lost {self.url} on read: {exc}")
            return b""
        self.bytes_read += len(data)
        return bytes(data)

    def drain(self) -> bool:
        """Wait until written bytes have left (before closing on shutdown); False on error."""
        if self._port is None:
            return False
        try:
            self._port.flush()
        except Exception as exc:
            self._drop(f"lost {self.url} on drain: {exc}")
            return False
        return True

    def close(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            with contextlib.suppress(Exception):
                port.close()
