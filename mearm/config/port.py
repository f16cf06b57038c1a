"""Which serial ports the backends open: device paths and three pyserial URL schemes.

pyserial's ``serial_for_url`` treats any ``<scheme>://`` as a protocol handler, and some
handlers do more than talk to a board: ``spy://…?file=PATH`` writes (and truncates)
``PATH``, ``hwgrep://`` opens whichever port matches a pattern, ``alt://`` picks a class
by name, ``cp2110://`` opens a HID device. :func:`check_port` lets through a device path
(``/dev/ttyACM0``, ``COM3``) and the URL schemes of :data:`ALLOWED_URL_SCHEMES` only.

A network URL (``socket://``, ``rfc2217://``) is checked whole too: a host, a TCP port 1
to 65535 and only the options pyserial reads. pyserial's own refusal of one (a port out
of range, none, an unknown option) reads ``'debug|info|warning|error'`` or ``'<=' not
supported…`` (its message is formatted with the braces of its own help), found only
when the port opens.

It lives with the config (it imports nothing from mearm but its exceptions): the
``servo.port`` validator calls it when a config loads, and the serial backends call it
again where they open the port.
"""

from __future__ import annotations

import math
from urllib.parse import parse_qs, urlsplit

from mearm.config.errors import SerialPortError

#: URL schemes opened besides device paths: a TCP socket, RFC 2217 (a networked serial
#: port) and the loopback used in tests. None of them touches a file.
ALLOWED_URL_SCHEMES: tuple[str, ...] = ("socket", "rfc2217", "loop")

#: The network schemes (``SCHEME://HOST:PORT``) and the options pyserial reads from each
#: one's query (``?logging=debug``); any other option it refuses as it opens the port.
NETWORK_URL_OPTIONS: dict[str, tuple[str, ...]] = {
    "socket": ("logging",),
    "rfc2217": ("logging", "ign_set_control", "poll_modem", "timeout"),
}

#: The values of a network URL's ``logging`` option (pyserial's levels).
LOGGING_LEVELS: tuple[str, ...] = ("debug", "info", "warning", "error")


def check_port(text: object) -> str:
    """``text`` itself if it is a device path or a URL of an allowed scheme.

    The scheme is compared case-insensitively, as pyserial looks it up.

    Args:
        text: The value of ``servo.port`` (or a ``port=`` override).

    Returns:
        ``text``, unchanged.

    Raises:
        SerialPortError: not a string, empty, surrounded by spaces, holding a control
            character, a URL whose scheme is not in :data:`ALLOWED_URL_SCHEMES`, or a
            network URL without a host, without a TCP port 1 to 65535, or with an option
            pyserial does not read (:data:`NETWORK_URL_OPTIONS`).
    """
    allowed = ALLOWED_URL_SCHEMES
    if not isinstance(text, str):
        raise SerialPortError(text, f"must be a string, not {type(text).__name__}", allowed)
    if not text.strip():
        raise SerialPortError(text, "is empty", allowed)
    if text != text.strip():
        raise SerialPortError(text, "has whitespace around it", allowed)
    if any(ord(c) < 0x20 or ord(c) == 0x7F for c in text):
        raise SerialPortError(text, "holds a control character", allowed)
    if "://" in text:
        scheme = text.split("://", 1)[0]
        if scheme.lower() not in allowed:
            raise SerialPortError(text, f"the URL scheme {scheme!r} is not allowed", allowed)
        if scheme.lower() in NETWORK_URL_OPTIONS:
            reason = _network_url_problem(text, scheme.lower())
            if reason is not None:
                raise SerialPortError(text, reason, allowed)
    return text


def _network_url_problem(url: str, scheme: str) -> str | None:
    """What is wrong with a ``socket://`` or ``rfc2217://`` URL, or ``None``."""
    form = f"({scheme}://HOST:PORT, PORT 1 to 65535)"
    try:
        parts = urlsplit(url)
    except ValueError:  # an unclosed IPv6 bracket
        return f"is not a URL {form}"
    if not parts.hostname:
        return f"names no host {form}"
    try:
        port = parts.port
    except ValueError:  # not a number, or past 65535
        port = -1
    if port is None:
        return f"names no TCP port {form}"
    if not 1 <= port <= 65535:
        given = parts.netloc.rsplit(":", 1)[-1]
        return f"its TCP port {given!r} is not 1 to 65535 ({scheme}://HOST:PORT)"
    options = NETWORK_URL_OPTIONS[scheme]
    for name, values in parse_qs(parts.query, keep_blank_values=True).items():
        if name not in options:
            return f"the option {name!r} is not one of {scheme}://'s ({', '.join(options)})"
        value = values[0]
        if name == "logging" and value not in LOGGING_LEVELS:
            return f"logging={value!r} is not one of {', '.join(LOGGING_LEVELS)}"
        if name == "timeout" and not _positive_seconds(value):
            return f"timeout={value!r} is not a number of seconds above 0"
    return None


def _positive_seconds(text: str) -> bool:
    """Whether ``text`` is a finite number above 0 (a network timeout in seconds)."""
    try:
        seconds = float(text)
    except ValueError:
        return False
    return math.isfinite(seconds) and seconds > 0
