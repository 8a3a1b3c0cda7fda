"""HTTP for scripts/fetch_test_data.sh: whole files, and byte ranges of a remote zip.

Standard library only (urllib). KITTI's frames sit in a 22 GB zip; `RangeFile` is a
seekable, read-only file over HTTP Range requests, so that `zipfile` reads the central
directory and the few members needed and nothing else. A server that ignores Range
(answers 200 with the whole body) is refused rather than read to the end.
"""

import io
import os
import time
import urllib.error
import urllib.parse
import urllib.request

USER_AGENT = "lfast-fetch-test-data/1"
TIMEOUT_S = 60
RETRIES = 3
BLOCK = 4 << 20  # bytes per ranged request when reading small pieces
CACHE_BYTES = 64 << 20


class FetchError(RuntimeError):
    """A download that failed; the message names the URL and the reason."""


def with_mirror(url, mirror):
    """`url` with its scheme and host replaced by `mirror` (which may carry a path prefix).

    https://host/a/b.zip with mirror http://127.0.0.1:8000/m gives http://127.0.0.1:8000/m/a/b.zip.
    """
    if not mirror:
        return url
    parts = urllib.parse.urlsplit(url)
    return mirror.rstrip("/") + parts.path + (("?" + parts.query) if parts.query else "")


def _open(url, headers=None):
    """urlopen with a few retries on network errors and 5xx answers."""
    req = urllib.request.Request(url, headers={"User-Agent": USER_AGENT, **(headers or {})})
    last = None
    for attempt in range(RETRIES):
        try:
            return urllib.request.urlopen(req, timeout=TIMEOUT_S)
        except urllib.error.HTTPError as e:
            if e.code < 500:
                raise FetchError(f"{url}: HTTP {e.code} {e.reason}") from e
            last = f"HTTP {e.code} {e.reason}"
        except (urllib.error.URLError, OSError) as e:
            last = str(getattr(e, "reason", e))
        time.sleep(1 + 2 * attempt)
    raise FetchError(f"{url}: {last} (after {RETRIES} tries)")


def download(url, dest):
    """Writes the body of `url` to the file `dest`; returns its size."""
    size = 0
    with _open(url) as resp, open(dest, "wb") as out:
        while True:
            chunk = resp.read(1 << 20)
            if not chunk:
                break
            out.write(chunk)
            size += len(chunk)
    return size


def _content_range_total(value, url):
    # "bytes START-END/TOTAL"
    try:
        return int(value.rsplit("/", 1)[1])
    except (AttributeError, IndexError, ValueError):
        raise FetchError(f"{url}: no usable Content-Range in a 206 answer ({value!r})") from None


class RangeFile(io.RawIOBase):
    """A remote file read with HTTP Range requests (seekable, read-only).

    A read that the kept pieces do not cover fetches from its start on, at least a
    BLOCK, and keeps what it got (the last CACHE_BYTES).
    `requests` and `fetched` count what went over the network."""

    def __init__(self, url):
        super().__init__()
        self.url = url
        self.pos = 0
        self.requests = 0
        self.fetched = 0
        self._cache = []  # (start, bytes), most recent last
        tail_start, tail, self.size = self._get_range(f"bytes=-{BLOCK}")
        self._remember(tail_start, tail)

    def _get_range(self, spec):
        resp = _open(self.url, {"Range": spec})
        with resp:
            if resp.status != 206:
                length = resp.headers.get("Content-Length", "unknown")
                raise FetchError(
                    f"{self.url}: the server ignored the Range request (HTTP {resp.status}, "
                    f"{length} bytes); refusing to download the whole archive. "
                    "Download it yourself and pass its folder with --archives DIR."
                )
            total = _content_range_total(resp.headers.get("Content-Range"), self.url)
            first = int(resp.headers["Content-Range"].split()[1].split("-")[0])
            data = resp.read()
        self.requests += 1
        self.fetched += len(data)
        return first, data, total

    def _remember(self, start, data):
        self._cache.append((start, data))
        while sum(len(d) for _, d in self._cache) > CACHE_BYTES and len(self._cache) > 1:
            self._cache.pop(0)

    def readable(self):
        return True

    def seekable(self):
        return True

    def tell(self):
        return self.pos

    def seek(self, offset, whence=os.SEEK_SET):
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self.pos, os.SEEK_END: self.size}[whence]
        if base + offset < 0:
            raise ValueError("negative seek position")
        self.pos = base + offset
        return self.pos

    def read(self, n=-1):
        if n is None or n < 0:
            n = self.size - self.pos
        end = min(self.pos + n, self.size)
        if end <= self.pos:
            return b""
        for start, data in reversed(self._cache):
            if start <= self.pos and end <= start + len(data):
                out = data[self.pos - start : end - start]
                self.pos = end
                return out
        # from here on, at least a BLOCK: sequential reads fetch each byte once
        first = self.pos
        last = min(max(end, first + BLOCK), self.size)
        start, data, _ = self._get_range(f"bytes={first}-{last - 1}")
        if start != first or len(data) != last - first:
            raise FetchError(f"{self.url}: asked for bytes {first}-{last - 1}, got {len(data)} bytes from {start}")
        self._remember(start, data)
        out = data[self.pos - start : end - start]
        self.pos = end
        return out

    def readinto(self, b):
        data = self.read(len(b))
        b[: len(data)] = data
        return len(data)
