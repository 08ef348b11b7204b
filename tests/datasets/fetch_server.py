"""A loopback HTTP server for the fetch tests (``tzsl data fetch``, a study's first-use fetch): never the network.

:func:`serve_folder` serves a folder on 127.0.0.1 through :class:`MisbehavingHandler` (which also
misbehaves on request, under the prefixes it lists) and records every path requested, so a test
can assert that a fetch made no request at all. :func:`registry_of` writes a small registry file
and loads it as tzsl's own is loaded.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pooch

#: How long a misbehaving handler of the test server goes on at most (s): every test stays bounded.
HANDLER_LIMIT_S = 20.0
#: Seconds between two bytes of the slow-drip paths.
DRIP_S = 0.25


class MisbehavingHandler(http.server.SimpleHTTPRequestHandler):
    """Serves a folder, except under these prefixes (the rest of the path is ignored):

    /drip/...        headers (Content-Length 1000), then 1 byte every DRIP_S
    /header-drip/... the status line and headers themselves, 1 byte every DRIP_S
    /stall/...       headers, then nothing
    /truncate/...    headers (Content-Length 1000), 10 bytes, then the connection closes
    /status/CODE/... that HTTP status
    /flaky/...       HTTP 500 on the first request of a path, then the file (the rest of the path)

    Every requested path is appended to ``requested``.
    """

    stop: threading.Event
    seen: dict[str, int]
    requested: list[str]

    def log_message(self, *args) -> None:
        pass

    def _slowly(self, data: bytes) -> None:
        end = time.monotonic() + HANDLER_LIMIT_S
        for i in range(len(data)):
            if self.stop.wait(DRIP_S) or time.monotonic() > end:
                return
            try:
                self.wfile.write(data[i:i + 1])
                self.wfile.flush()
            except OSError:  # the client gave up
                return

    def do_GET(self) -> None:
        self.requested.append(self.path)
        kind, _, rest = self.path.lstrip("/").partition("/")
        if kind in ("drip", "stall", "truncate"):
            self.send_response(200)
            self.send_header("Content-Length", "1000")
            self.end_headers()
            if kind == "drip":
                self._slowly(b"x" * 1000)
            elif kind == "stall":
                self.stop.wait(HANDLER_LIMIT_S)
            else:
                self.wfile.write(b"x" * 10)
        elif kind == "header-drip":
            self._slowly(b"HTTP/1.0 200 OK\r\nContent-Length: 1000\r\n\r\n" + b"x" * 1000)
        elif kind == "status":
            code = int(rest.split("/", 1)[0])
            self.send_error(code)
        elif kind == "flaky":
            self.seen[rest] = self.seen.get(rest, 0) + 1
            if self.seen[rest] == 1:
                self.send_error(500)
            else:
                self.path = "/" + rest
                super().do_GET()
        else:
            super().do_GET()


@contextlib.contextmanager
def serve_folder(root: Path) -> Iterator[tuple[str, list[str]]]:
    """Serve ``root`` on a free loopback port; yields (base URL, the paths requested so far).
    Stops on exit, its slow handlers too."""
    stop = threading.Event()
    requested: list[str] = []
    handler = type("Handler", (MisbehavingHandler,), {"stop": stop, "seen": {}, "requested": requested})
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(handler, directory=str(root)))
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}", requested
    finally:
        stop.set()
        httpd.shutdown()
        httpd.server_close()


def registry_of(path: Path, lines: list[str]) -> pooch.Pooch:
    """Write registry ``lines`` (``<path> <alg:hash> [url]``) to ``path`` and load them as tzsl loads its own."""
    path.write_text("\n".join(lines) + "\n")
    pup = pooch.create(path=".", base_url="", registry=None)
    pup.load_registry(str(path))
    return pup
