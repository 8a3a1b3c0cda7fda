"""A local HTTP server on 127.0.0.1 for the tests of scripts/fetch_test_data.sh.

Serves a folder (laid out as the public origins lay out their files) with single
byte-range support (bytes=A-B, bytes=A-, bytes=-N), as S3 answers them, and logs
every request. Paths under /no-range/ ignore the Range header and answer 200 with
the whole file, as a server without range support does.
"""

import http.server
import threading


class Origin:
    def __init__(self, root):
        self.root = root
        self.log = []  # (method, path, Range header or None, bytes sent)
        handler = _handler(self)
        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.httpd.shutdown()
        self.httpd.server_close()

    def paths(self):
        return [path for _, path, _, _ in self.log]

    def sent(self, path):
        return sum(n for _, p, _, n in self.log if p == path)


def _parse_range(spec, size):
    """(first, last) inclusive, or None when unsatisfiable."""
    if not spec.startswith("bytes=") or "," in spec:
        return None
    a, _, b = spec[6:].partition("-")
    if a == "":
        n = int(b)
        return (max(0, size - n), size - 1) if n > 0 and size else None
    first = int(a)
    last = min(int(b), size - 1) if b else size - 1
    return (first, last) if first <= last else None


def _handler(origin):
    class Handler(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def log_message(self, *args):
            pass

        def do_HEAD(self):
            self._serve(body=False)

        def do_GET(self):
            self._serve(body=True)

        def _serve(self, body):
            path = self.path.split("?", 1)[0]
            rel = path.removeprefix("/no-range")
            file = origin.root / rel.lstrip("/")
            spec = self.headers.get("Range")
            if not file.is_file() or ".." in rel.split("/"):
                origin.log.append((self.command, path, spec, 0))
                self.send_error(404)
                return
            data = file.read_bytes()
            status, headers = 200, {}
            if spec and not path.startswith("/no-range/"):
                span = _parse_range(spec, len(data))
                if span is None:
                    origin.log.append((self.command, path, spec, 0))
                    self.send_response(416)
                    self.send_header("Content-Range", f"bytes */{len(data)}")
                    self.send_header("Content-Length", "0")
                    self.end_headers()
                    return
                first, last = span
                headers["Content-Range"] = f"bytes {first}-{last}/{len(data)}"
                data, status = data[first : last + 1], 206
            self.send_response(status)
            for k, v in headers.items():
                self.send_header(k, v)
            self.send_header("Content-Length", str(len(data)))
            self.send_header("Accept-Ranges", "bytes")
            self.end_headers()
            # logged before the body goes out, so that a client that has read it
            # finds the entry (a client that hangs up early still counts as sent)
            origin.log.append((self.command, path, spec, len(data) if body else 0))
            if body:
                try:
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client hung up, as it should on a 200 to a Range request

    return Handler
