"""Inputs read as seekable files that count what they read: local files, and ``http(s)://`` URLs
read by HTTP range requests (the standard library's urllib: no cache, nothing written).

A URL is read by ranges: a small read fetches a block of ``BLOCK`` bytes (the last ``KEPT``
blocks are kept in memory: a LAS header and its records are many small reads), a large one
exactly what it asks for, each a
``Range: bytes=a-b`` request with a time-out (``TIMEOUT``) and up to ``RETRIES`` retries after a
network error or a server error (5xx), waiting 0.5, 1, 2 s. A server that answers a range
request with the whole file (status 200, no ``Content-Range``) cannot serve a file by parts:
that is one line with the fix, download the file.
"""
from __future__ import annotations

import io
import os
import time
from typing import Any
from urllib.parse import unquote, urlsplit

from ..base.errors import LidarSigError, reason

#: Bytes fetched for a small read (a LAS header, its VLRs, a COPC hierarchy page).
BLOCK = 64 * 1024
#: Blocks kept in memory.
KEPT = 4
#: Seconds to wait for a server's answer.
TIMEOUT = 30.0
#: Attempts after the first when the network or the server fails.
RETRIES = 3
#: Bytes fetched so far by every URL read in this process (what progress shows).
FETCHED = [0]


def is_url(text: Any) -> bool:
    """Whether ``text`` is an ``http://`` or ``https://`` URL."""
    return isinstance(text, str) and text.lower().startswith(("http://", "https://"))


def url_name(text: str) -> str:
    """The path part of a URL (its query left out, %-escapes decoded), else ``text`` itself."""
    return unquote(urlsplit(text).path) if is_url(text) else str(text)


def open_input(source: str | os.PathLike[str]) -> Any:
    """A seekable binary file reading ``source`` (a path or URL) that counts ``bytes_read``
    (``remote`` True for a URL); a context manager."""
    if is_url(str(source)):
        return RangeFile(str(source))
    return _CountedFile(open(source, "rb"))


def fetch(url: str) -> bytes:
    """The whole content of a small file at ``url`` (a .vpc)."""
    with RangeFile(url) as fh:
        return fh.read()


class _CountedFile(io.RawIOBase):
    """A local file that counts the bytes read from it."""

    remote = False

    def __init__(self, fh: Any) -> None:
        self._fh = fh
        self.bytes_read = 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def readinto(self, b: Any) -> int:
        n = self._fh.readinto(b)
        self.bytes_read += n or 0
        return n

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._fh.seek(offset, whence)

    def tell(self) -> int:
        return self._fh.tell()

    def close(self) -> None:
        self._fh.close()
        super().close()


class RangeFile(io.RawIOBase):
    """A file on a web server read by HTTP range requests: seekable, counting ``bytes_read``."""

    remote = True

    def __init__(self, url: str, *, timeout: float = TIMEOUT, retries: int = RETRIES) -> None:
        self.url, self.timeout, self.retries = url, timeout, retries
        self.bytes_read = 0
        self.requests = 0
        self._pos = 0
        first, self.size = self._get(0, BLOCK - 1)
        self._blocks = [(0, first)]  # (start, bytes), the latest last

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = 0) -> int:
        self._pos = {0: 0, 1: self._pos, 2: self.size}[whence] + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def readinto(self, b: Any) -> int:
        n = min(len(b), self.size - self._pos)
        if n <= 0:
            return 0
        for start, data in self._blocks:
            if start <= self._pos and self._pos + n <= start + len(data):
                break
        else:
            end = min(self.size, self._pos + (BLOCK if n < BLOCK // 4 else n)) - 1
            start, data = self._pos, self._get(self._pos, end)[0]
            self._blocks = (self._blocks + [(start, data)])[-KEPT:]
        at = self._pos - start
        memoryview(b)[:n] = data[at:at + n]
        self._pos += n
        return n

    def _get(self, start: int, end: int) -> tuple[bytes, int]:
        """(bytes start..end inclusive, the file's size) by one range request, retried."""
        import urllib.error
        import urllib.request

        request = urllib.request.Request(self.url, headers={"Range": f"bytes={start}-{end}",
                                                            "User-Agent": "lidar-sig"})
        for attempt in range(self.retries + 1):
            try:
                with urllib.request.urlopen(request, timeout=self.timeout) as answer:
                    span = answer.headers.get("Content-Range")
                    if answer.status != 206 or not span:
                        raise LidarSigError("the server does not answer byte-range requests, so the file cannot be "
                                            "read by parts; download it and give the local file", path=self.url)
                    data = answer.read()
                self.requests += 1
                self.bytes_read += len(data)
                FETCHED[0] += len(data)
                total = span.rsplit("/", 1)[-1]
                return data, int(total) if total.strip().isdigit() else start + len(data)
            except urllib.error.HTTPError as exc:
                if exc.code == 416:  # a range past the end: an empty file
                    return b"", 0
                if exc.code < 500 or attempt == self.retries:
                    raise LidarSigError(f"the server answered HTTP {exc.code} ({exc.reason}); check the URL",
                                        path=self.url) from None
            except (urllib.error.URLError, OSError) as exc:
                if attempt == self.retries:
                    raise LidarSigError(f"cannot be fetched after {self.retries + 1} attempts ({reason(exc)}); "
                                        "check the address and the network", path=self.url) from None
            time.sleep(0.5 * 2**attempt)
        raise AssertionError("unreachable")
