"""The meshcat view's scene as a browser connecting now would receive it (for the view tests)."""

from __future__ import annotations

import base64
import re

import numpy as np
import umsgpack

from mearm.view import ArmView


def scene(view: ArmView) -> dict[str, dict]:
    """The server's scene tree, as a browser connecting now would receive it.

    Returns ``{path: {"object": …, "transform": 4x4 array, "properties": {…}}}`` decoded
    from the commands the server replays (meshcat's ``get_scene``).
    """
    html = view.viewer.static_html()
    out: dict[str, dict] = {}
    for blob in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html):
        cmd = umsgpack.unpackb(base64.b64decode(blob))
        node = out.setdefault(cmd["path"], {})
        if cmd["type"] == "set_object":
            node["object"] = cmd["object"]
        elif cmd["type"] == "set_transform":
            node["transform"] = np.array(cmd["matrix"], dtype=float).reshape(4, 4).T
        elif cmd["type"] == "set_property":
            node.setdefault("properties", {})[cmd["property"]] = cmd["value"]
    return out
