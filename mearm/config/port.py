"""Which serial ports the backends open: device paths and three pyserial URL schemes.

pyserial's ``serial_for_url`` treats any ``<scheme>://`` as a protocol handler, and some
handlers do more than talk to a board: ``spy://…?file=PATH`` writes (and truncates)
``PATH``, ``hwgrep://`` opens whichever port matches a pattern, ``alt://`` picks a class
by name, ``cp2110://`` opens a HID device. :func:`check_port` lets through a device path
(``/dev/ttyACM0``, ``COM3``) and the URL schemes of :data:`ALLOWED_URL_SCHEMES` only.

It lives with the config (it imports nothing from mearm but its exceptions): the
``servo.port`` validator calls it when a config loads, and the serial backends call it
again where they open the port.
"""

from __future__ import annotations

from mearm.config.errors import SerialPortError

#: URL schemes opened besides device paths: a TCP socket, RFC 2217 (a networked serial
#: port) and the loopback used in tests. None of them touches a file.
ALLOWED_URL_SCHEMES: tuple[str, ...] = ("socket", "rfc2217", "loop")


def check_port(text: object) -> str:
    """``text`` itself if it is a device path or a URL of an allowed scheme.

    The scheme is compared case-insensitively, as pyserial looks it up.

    Args:
        text: The value of ``servo.port`` (or a ``port=`` override).

    Returns:
        ``text``, unchanged.

    Raises:
        SerialPortError: not a string, empty, surrounded by spaces, holding a control
            character, or a URL whose scheme is not in :data:`ALLOWED_URL_SCHEMES`.
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
    return text
