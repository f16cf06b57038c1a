"""A meshcat server that listens on 127.0.0.1 only, run in a background thread.

meshcat-python's own server (``meshcat.servers.zmqserver``) binds its web port on every
interface and runs as a separate process. This module reuses its ZMQ ↔ WebSocket bridge
(the scene tree it keeps and replays to every browser that connects, the static viewer
files) but listens on the loopback interface only and runs in a daemon thread of the
calling process, so it starts in milliseconds and cannot outlive the program.

Listening on the loopback is not enough: a web page from anywhere can make the browser
send requests to 127.0.0.1 under a name it controls (DNS rebinding), or open a WebSocket
to it from its own origin. So every request — page, static file or WebSocket upgrade —
is answered 403 unless its ``Host`` names the loopback (``127.0.0.1``, ``localhost`` or
``[::1]``, with this server's port or none) and its ``Origin``, when it has one, is
``http://`` one of those names with this server's port (:func:`loopback_request`).
"""

from __future__ import annotations

import asyncio
import re
import socket
import threading
from typing import Any
from urllib.parse import urlsplit

import tornado.httpserver
import tornado.httputil
import tornado.ioloop
import tornado.netutil
import tornado.web
import zmq
from meshcat.servers.tree import SceneTree, walk
from meshcat.servers.zmqserver import (
    VIEWER_HTML,
    VIEWER_ROOT,
    StaticFileHandlerNoCache,
    WebSocketHandler,
    ZMQWebSocketBridge,
)
from meshcat.visualizer import ViewerWindow

from mearm.view.browser import SceneCounts
from mearm.view.errors import ViewError, ViewPortError, ViewRunError

LOOPBACK = "127.0.0.1"
#: First web port tried when none is given (meshcat's own default), and how many after it.
DEFAULT_PORT = 7000
PORT_ATTEMPTS = 100


#: The host names this server answers to (lower case); ``Host`` may add its port.
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
_HOST = re.compile(r"(?P<name>\[[^\]]*\]|[^:\[\]]*)(?::(?P<port>[0-9]{1,5}))?")


def loopback_request(headers: tornado.httputil.HTTPHeaders, port: int | None) -> bool:
    """Whether a request's ``Host`` and ``Origin`` both name this loopback server.

    Args:
        headers: The request's headers.
        port: The server's port (``None``: not known yet, any port).

    Returns:
        ``Host`` is present and is a name of :data:`LOOPBACK_NAMES` with ``port`` or no
        port; ``Origin`` is absent or is ``http://`` such a name with ``port`` itself (an
        origin without a port is port 80).
    """
    hosts = headers.get_list("Host")
    if len(hosts) != 1 or not _loopback(hosts[0], port, default_port=None):
        return False
    origins = headers.get_list("Origin")
    if not origins:
        return True
    if len(origins) != 1:
        return False
    parts = urlsplit(origins[0])
    if parts.scheme.lower() != "http" or parts.path or parts.query or parts.fragment:
        return False
    return "@" not in parts.netloc and _loopback(parts.netloc, port, default_port=80)


def _loopback(netloc: str, port: int | None, *, default_port: int | None) -> bool:
    match = _HOST.fullmatch(netloc.strip())
    if match is None or match["name"].lower() not in LOOPBACK_NAMES:
        return False
    given = int(match["port"]) if match["port"] is not None else default_port
    return port is None or given is None or given == port


class _LoopbackApplication(tornado.web.Application):
    """A tornado application that answers 403 to any request not for the loopback server.

    Attributes:
        port: The port it is served on (set once listening).
    """

    port: int | None = None

    def find_handler(  # noqa: D102
        self, request: tornado.httputil.HTTPServerRequest, **kwargs: Any
    ) -> Any:
        if not loopback_request(request.headers, self.port):
            forbidden = {"status_code": 403}
            return self.get_handler_delegate(request, tornado.web.ErrorHandler, forbidden)
        return super().find_handler(request, **kwargs)


class _QuietWebSocketHandler(WebSocketHandler):
    """meshcat's handler without its ``opened: <…>`` / ``closed: <…>`` lines on stderr."""

    def check_origin(self, origin: str) -> bool:
        """The application has checked ``Host`` and ``Origin`` already (403 otherwise)."""
        return True

    def open(self) -> None:  # noqa: D102
        self.bridge.websocket_pool.add(self)
        self.bridge.send_scene(self)

    def on_close(self) -> None:  # noqa: D102
        self.bridge.websocket_pool.discard(self)


def _bind(port: int) -> list[socket.socket]:
    if not 0 <= port <= 65535:  # getaddrinfo would silently take it modulo 65536
        raise ViewPortError(port, "not a TCP port (0..65535)")
    try:
        return tornado.netutil.bind_sockets(port, address=LOOPBACK)
    except (OSError, OverflowError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ViewPortError(port, reason) from None


def _listen(app: tornado.web.Application, port: int | None) -> tuple[Any, int]:
    """Serve ``app`` on 127.0.0.1: on ``port`` (0: any free one), or the first free from 7000."""
    if port is not None:
        sockets = _bind(port)
    else:
        for candidate in range(DEFAULT_PORT, DEFAULT_PORT + PORT_ATTEMPTS):
            try:
                sockets = _bind(candidate)
                break
            except ViewPortError:
                continue
        else:
            raise ViewError(
                f"no free port in {DEFAULT_PORT}..{DEFAULT_PORT + PORT_ATTEMPTS - 1} on "
                f"{LOOPBACK}; pass a port explicitly"
            )
    server = tornado.httpserver.HTTPServer(app)
    server.add_sockets(sockets)
    return server, sockets[0].getsockname()[1]


class LoopbackBridge(ZMQWebSocketBridge):
    """meshcat's ZMQ ↔ WebSocket bridge, bound to 127.0.0.1 only.

    The ZMQ command socket takes an ephemeral loopback port; the web server takes
    ``port`` (or the first free port from 7000). Must be built in the thread whose
    event loop will run it.

    Args:
        port: Web port; 0 for any free one; ``None`` for the first free one from 7000.

    Raises:
        ViewPortError: ``port`` is in use or not a port.
    """

    def __init__(self, port: int | None = None):  # the parent's __init__ binds everywhere
        self.host = LOOPBACK
        self.websocket_pool: set[WebSocketHandler] = set()
        self.tree = SceneTree()
        self.ioloop = tornado.ioloop.IOLoop.current()
        self.app = self.make_app()
        self.http_server, self.fileserver_port = _listen(self.app, port)
        self.app.port = self.fileserver_port
        self.zmq_socket, self.zmq_stream, _ = self.setup_zmq(f"tcp://{LOOPBACK}:*")
        self.zmq_url = self.zmq_socket.getsockopt_string(zmq.LAST_ENDPOINT)
        self.web_url = f"http://{LOOPBACK}:{self.fileserver_port}/static/"

    def make_app(self) -> _LoopbackApplication:
        """The viewer's static files and the WebSocket the browser connects to.

        Requests whose ``Host`` or ``Origin`` is not this loopback server get 403.
        """
        return _LoopbackApplication(
            [
                (
                    r"/static/(.*)",
                    StaticFileHandlerNoCache,
                    {"path": VIEWER_ROOT, "default_filename": VIEWER_HTML},
                ),
                (r"/", _QuietWebSocketHandler, {"bridge": self}),
            ],
            log_function=lambda handler: None,  # no access log lines on our stderr
        )

    def shutdown(self) -> None:
        """Stop listening and close every socket (call in the loop's thread)."""
        self.http_server.stop()
        for ws in list(self.websocket_pool):
            ws.close()
        self.zmq_stream.close(linger=0)


class _Window(ViewerWindow):
    """The client end of the ZMQ link, with a reply timeout.

    meshcat's window blocks forever when the server does not answer; this one raises
    :class:`ViewRunError` after ``timeout_s``.
    """

    def __init__(self, zmq_url: str, web_url: str, timeout_s: float):  # no server, no print
        self.server_proc = None
        self.zmq_url = zmq_url
        self.web_url = web_url
        self.timeout_ms = int(timeout_s * 1000)
        self.connect_zmq()

    def connect_zmq(self) -> None:  # noqa: D102
        self.zmq_socket = self.context.socket(zmq.REQ)
        self.zmq_socket.setsockopt(zmq.RCVTIMEO, self.timeout_ms)
        self.zmq_socket.setsockopt(zmq.SNDTIMEO, self.timeout_ms)
        self.zmq_socket.setsockopt(zmq.LINGER, 0)
        self.zmq_socket.connect(self.zmq_url)

    def send(self, command: Any) -> None:  # noqa: D102
        try:
            super().send(command)
        except zmq.ZMQError as exc:
            raise ViewRunError(
                f"the meshcat server at {self.web_url} did not answer within "
                f"{self.timeout_ms / 1000:g} s ({exc}); was the view closed?"
            ) from None

    def get_scene(self) -> str:  # noqa: D102
        try:
            return super().get_scene()
        except zmq.ZMQError as exc:
            raise ViewRunError(
                f"the meshcat server at {self.web_url} did not answer ({exc})"
            ) from None

    def close(self) -> None:
        """Close the client socket."""
        self.zmq_socket.close(linger=0)


class MeshcatServer:
    """A :class:`LoopbackBridge` serving from a daemon thread.

    Args:
        port: Web port; 0 for any free one; ``None`` for the first free one from 7000.
        timeout_s: How long to wait for the server to start, and for each reply [s].

    Attributes:
        web_url: The viewer's address, ``http://127.0.0.1:<port>/static/``.
        zmq_url: The command socket's address, ``tcp://127.0.0.1:<port>``.
        port: The web port.

    Raises:
        ViewPortError: ``port`` is in use.
        ViewError: No free port from 7000 (``port=None``).
        ViewRunError: The server did not start in time.
    """

    def __init__(self, port: int | None = None, timeout_s: float = 10.0):
        self.timeout_s = timeout_s
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._bridge: LoopbackBridge | None = None
        self._thread = threading.Thread(
            target=self._serve, args=(port,), name="meshcat-server", daemon=True
        )
        self._thread.start()
        if not self._ready.wait(timeout_s):
            raise ViewRunError(f"the meshcat server did not start within {timeout_s:g} s")
        if self._error is not None:
            raise self._error
        assert self._bridge is not None
        self.web_url: str = self._bridge.web_url
        self.zmq_url: str = self._bridge.zmq_url
        self.port: int = self._bridge.fileserver_port

    def _serve(self, port: int | None) -> None:
        loop = asyncio.new_event_loop()
        asyncio.set_event_loop(loop)
        try:
            self._bridge = LoopbackBridge(port)
        except BaseException as exc:  # handed to the starting thread
            self._error = exc
            self._ready.set()
            loop.close()
            return
        self._ready.set()
        ioloop = self._bridge.ioloop
        try:
            ioloop.start()
        finally:
            self._bridge.shutdown()
            ioloop.close(all_fds=True)

    @property
    def running(self) -> bool:
        """Whether the server thread is alive."""
        return self._thread.is_alive()

    @property
    def browsers(self) -> int:
        """How many browsers are connected now."""
        return len(self._bridge.websocket_pool) if self._bridge and self.running else 0

    def scene_counts(self) -> SceneCounts:
        """How many commands a browser connecting now receives, and objects under /meshcat.

        Raises:
            ViewRunError: The server is not running (it stopped, or was closed).
        """
        if self._bridge is None or not self.running:
            raise ViewRunError(f"the meshcat server at {self.web_url} is not running")
        messages = 0
        for node in walk(self._bridge.tree):
            messages += (node.object is not None) + len(node.properties)
            messages += (node.transform is not None) + (node.animation is not None)
        root = self._bridge.tree.get("meshcat")
        objects = sum(node.object is not None for node in walk(root)) if root is not None else 0
        return SceneCounts(messages=messages, objects=objects)

    def window(self) -> _Window:
        """A new client connection for ``meshcat.Visualizer(window=...)``."""
        return _Window(self.zmq_url, self.web_url, self.timeout_s)

    def close(self) -> None:
        """Stop the server and free its ports; safe to call twice."""
        if self._bridge is not None and self._thread.is_alive():
            self._bridge.ioloop.add_callback(self._bridge.ioloop.stop)
            self._thread.join(self.timeout_s)
