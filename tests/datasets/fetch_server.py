"""A loopback HTTP server for the fetch tests (``tzsl data fetch``, a study's first-use fetch): never the network.

:func:`serve_folder` serves a folder on 127.0.0.1 through :class:`MisbehavingHandler` (which also
misbehaves on request, under the prefixes it lists) and records every path requested, so a test
can assert that a fetch made no request at all. :func:`registry_of` writes a small registry file
and loads it as tzsl's own is loaded.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
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


class Requested(list):
    """The paths a test server was asked for, in order; ``ports``: the client ports they came
    from (one per connection: fewer ports than paths means kept-alive connections)."""

    def __init__(self) -> None:
        super().__init__()
        self.ports: set[int] = set()


class MisbehavingHandler(http.server.SimpleHTTPRequestHandler):
    """Serves a folder, except under these prefixes (the rest of the path is ignored):

    /drip/...        headers (Content-Length 1000), then 1 byte every DRIP_S
    /header-drip/... the status line and headers themselves, 1 byte every DRIP_S
    /stall/...       headers, then nothing
    /truncate/...    headers (Content-Length 1000), 10 bytes, then the connection closes
    /status/CODE/... that HTTP status
    /flaky/...       HTTP 500 on the first request of a path, then the file (the rest of the path)

    Every requested path is appended to ``requested`` (and the client's port, one per connection,
added to ``requested.ports``); every answer waits ``delay_s`` first (the
    round trip of a distant server). HTTP/1.1: a client may reuse its connection (keep-alive), as
    with GitHub; the misbehaving answers close theirs.
    """

    protocol_version = "HTTP/1.1"
    disable_nagle_algorithm = True  # as a web server does: a kept-alive connection's small answers go out at once
    stop: threading.Event
    seen: dict[str, int]
    requested: Requested
    delay_s: float = 0.0

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
        self.requested.ports.add(self.client_address[1])
        if self.delay_s and self.stop.wait(self.delay_s):
            return
        kind, _, rest = self.path.lstrip("/").partition("/")
        if kind in ("drip", "stall", "truncate"):
            self.close_connection = True
            self.send_response(200)
            self.send_header("Content-Length", "1000")
            self.send_header("Connection", "close")
            self.end_headers()
            if kind == "drip":
                self._slowly(b"x" * 1000)
            elif kind == "stall":
                self.stop.wait(HANDLER_LIMIT_S)
            else:
                self.wfile.write(b"x" * 10)
        elif kind == "header-drip":
            self.close_connection = True
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
def serve_folder(root: Path, delay_s: float = 0.0) -> Iterator[tuple[str, Requested]]:
    """Serve ``root`` on a free loopback port, each answer ``delay_s`` seconds late; yields (base
    URL, the paths requested so far). Stops on exit, its slow handlers too."""
    stop = threading.Event()
    requested = Requested()
    handler = type("Handler", (MisbehavingHandler,), {"stop": stop, "seen": {}, "requested": requested,
                                                      "delay_s": delay_s})
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


@contextlib.contextmanager
def registered_release(folder: Path, files: dict[str, bytes], registry_file: Path, monkeypatch) -> Iterator[str]:
    """Serve ``folder`` on 127.0.0.1 and register ``files`` (registered path -> content) at it, instead of
    tzsl's registry, for the test's duration (a catalog dataset's small release); yields the base URL."""
    from tzsl.datasets import _fetch, _registry

    with serve_folder(folder) as (base, _requested):
        pup = registry_of(registry_file, [f"{r} sha256:{hashlib.sha256(c).hexdigest()} {base}/{r}"
                                          for r, c in files.items()])
        monkeypatch.setattr(_registry, "registry", lambda: pup)
        monkeypatch.setattr(_fetch, "registry", lambda: pup)
        yield base


def run_cli(*args) -> tuple[int, str, str]:
    """``tzsl ARGS`` in-process: exit code, standard output, standard error."""
    from click.testing import CliRunner

    from tzsl.cli import cli

    result = CliRunner().invoke(cli, [str(a) for a in args])
    return result.exit_code, result.stdout, result.stderr


def main(argv: list[str] | None = None) -> None:
    """``python -m tests.datasets.fetch_server FOLDER [--delay S]``: serve FOLDER (e.g. the shared
    data, as a mirror) until stopped, printing its base URL first (the fetch benchmark's server)."""
    import argparse

    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("folder", type=Path)
    parser.add_argument("--delay", type=float, default=0.0, help="seconds each answer waits (a distant server)")
    args = parser.parse_args(argv)
    with serve_folder(args.folder, delay_s=args.delay) as (base, _requested):
        print(base, flush=True)
        threading.Event().wait()


if __name__ == "__main__":
    main()
