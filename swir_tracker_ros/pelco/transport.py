# SPDX-License-Identifier: Apache-2.0
"""Server side of the simulated head's serial line: a pseudo-terminal or a loopback TCP port."""

from __future__ import annotations

import contextlib
import os
import socket
import tty


class PtyTransport:
    """A pty pair from os.openpty (no socat). The slave path changes on every reopen, so `link` (a symlink
    kept pointing at the current slave and removed while closed) gives clients a stable port name."""

    def __init__(self, link: str | None = None) -> None:
        self.link = link
        self.master: int | None = None
        self.slave: int | None = None
        self.path = ""

    def open(self) -> str:
        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: the line carries binary frames
        os.set_blocking(master, False)
        self.master, self.slave, self.path = master, slave, os.ttyname(slave)
        if self.link:
            tmp = f"{self.link}.tmp{os.getpid()}"
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            os.symlink(self.path, tmp)
            os.replace(tmp, self.link)
        return f"PTY {self.link or self.path}"

    def fds(self) -> list[int]:
        return [self.master] if self.master is not None else []

    def readable(self, fd: int) -> bytes:
        try:
            return os.read(fd, 4096)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:  # EIO: no client has the slave open right now
            return b""

    def write(self, data: bytes) -> None:
        if self.master is not None:
            with contextlib.suppress(BlockingIOError, OSError):
                os.write(self.master, data)

    def close(self) -> None:
        if self.link:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link)
        for fd in (self.master, self.slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self.master = self.slave = None


class TcpTransport:
    """One client at a time on 127.0.0.1 (a newer connection replaces the older, as device servers do);
    the port chosen at the first open is kept across reopens."""

    def __init__(self, port: int = 0, host: str = "127.0.0.1") -> None:
        self.host, self.port = host, port
        self.server: socket.socket | None = None
        self.client: socket.socket | None = None

    def open(self) -> str:
        srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        srv.bind((self.host, self.port))
        srv.listen(1)
        srv.setblocking(False)
        self.server, self.port = srv, srv.getsockname()[1]
        return f"TCP {self.host}:{self.port}"

    def fds(self) -> list[int]:
        return [s.fileno() for s in (self.server, self.client) if s is not None]

    def readable(self, fd: int) -> bytes:
        if self.server is not None and fd == self.server.fileno():
            try:
                conn, _ = self.server.accept()
            except (BlockingIOError, OSError):
                return b""
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._drop_client()
            self.client = conn
            return b""
        if self.client is None:
            return b""
        try:
            data = self.client.recv(4096)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            data = b""
        if not data:
            self._drop_client()
        return data

    def write(self, data: bytes) -> None:
        if self.client is not None:
            try:
                self.client.sendall(data)
            except OSError:
                self._drop_client()

    def _drop_client(self) -> None:
        if self.client is not None:
            with contextlib.suppress(OSError):
                self.client.close()
            self.client = None

    def close(self) -> None:
        self._drop_client()
        if self.server is not None:
            with contextlib.suppress(OSError):
                self.server.close()
            self.server = None
