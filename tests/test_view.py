"""The meshcat view: scene bookkeeping on a real server, the frame texture, Chromium renders.

The browser tests render the view in real headless Chromium and look for the arm's and
the objects' colours where the camera model (:meth:`ViewCamera.project`, checked
against the render here) says they are. They are skipped when no Chromium-family
browser exists, and fail instead when MEARM_REQUIRE_TOOLS=1 (CI). Every reference
config's arm (any number of joints, the jaws as joints) is drawn and rendered too.
"""

from __future__ import annotations

import importlib
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import urllib.request
from collections.abc import Callable
from functools import partial
from pathlib import Path

import cv2
import meshcat
import numpy as np
import pinocchio as pin
import pytest
from conftest import REFERENCE_CONFIGS, ROOT, browser_or_skip
from viewscene import scene

from mearm.cli import run
from mearm.config import Config, load_config
from mearm.exceptions import (
    BrowserNotFoundError,
    ViewError,
    ViewInputError,
    ViewPortError,
)
from mearm.kinematics import ArmModel, jaw_joint_names
from mearm.kinematics.bodies import bin_half_outer_m
from mearm.sim import SimCamera, World
from mearm.view import (
    ArmView,
    HeadlessBrowser,
    MeshcatServer,
    SceneLayout,
    ViewCamera,
    find_browser,
    frame_plane,
    rgb_int,
    screenshot,
)
from mearm.view.frame_plane import FramePlane
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
CLASSES = {c.name: c for c in CONFIG.task.classes}
W, H = 960, 600  # screenshot size [px]


# --------------------------------------------------------------------------- helpers


@pytest.fixture(scope="module")
def chromium():
    """One headless Chromium for this module's in-process renders (each in a tab of its
    own); ``test_preview_screenshot_renders_the_arm`` starts one as a user's command does."""
    with HeadlessBrowser(browser_or_skip()) as running:
        yield running


@pytest.fixture
def view(model: ArmModel):
    with ArmView(model, CONFIG) as v:
        yield v


@pytest.fixture(scope="module")
def refusing_view(model: ArmModel):
    """One server for the many requests that must be refused (a server each cost 40 ms of
    CPU, 2 s over them): each request stands alone, and one let through fails its test."""
    with ArmView(model, CONFIG) as v:
        yield v


def drawn(view: ArmView, prefix: str) -> set[str]:
    """Names of the objects drawn directly under ``/meshcat/<prefix>/``."""
    head = f"/meshcat/{prefix}/"
    return {p[len(head) :] for p, n in scene(view).items() if p.startswith(head) and "object" in n}


def object_color(node: dict) -> int:
    return node["object"]["materials"][0]["color"]


def urdf_visuals(model: ArmModel) -> tuple[pin.Model, pin.GeometryModel]:
    """The URDF's model with its jaw joints free, and its visual geometry."""
    full = pin.buildModelFromXML(model.urdf)
    return full, pin.buildGeomFromUrdfString(full, model.urdf, pin.GeometryType.VISUAL)


def urdf_q(full: pin.Model, model: ArmModel, q: np.ndarray, opening_cm: float) -> np.ndarray:
    """The URDF's q for chain joints ``q`` and each jaw at half the opening [m]."""
    out = pin.neutral(full)
    for name, value in zip(model.chain.names, q, strict=True):
        out[full.joints[full.getJointId(name)].idx_q] = value
    for name in jaw_joint_names(model.arm):
        out[full.joints[full.getJointId(name)].idx_q] = opening_cm / 200
    return out


def hsv_mask(img_bgr: np.ndarray, name: str) -> np.ndarray:
    """Pixels of a named colour (OpenCV HSV, H in 0..179)."""
    h, s, v = cv2.split(cv2.cvtColor(img_bgr, cv2.COLOR_BGR2HSV))
    sat = (s >= 150) & (v >= 60)
    bands = {
        "red": (h <= 6) | (h >= 174),
        "green": (h >= 55) & (h <= 80),
        "blue": (h >= 105) & (h <= 125),
        "orange": (h >= 10) & (h <= 22),
        "yellow": (h >= 23) & (h <= 35),
    }
    return bands[name] & sat


def fraction(mask: np.ndarray, uv: np.ndarray, half: int = 2) -> float:
    """Share of a (2·half+1)² window around pixel ``uv`` that is set in ``mask``."""
    u, v = np.round(uv).astype(int)
    return float(mask[v - half : v + half + 1, u - half : u + half + 1].mean())


# --------------------------------------------------------------------------- server


def _listening_addresses(port: int) -> list[str]:
    """Local addresses of the TCP sockets listening on ``port`` (Linux /proc)."""
    found = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not os.path.exists(table):
            continue
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, port_hex = local.split(":")
            if state == "0A" and int(port_hex, 16) == port:  # 0A: LISTEN
                found.append(addr)
    return found


def test_server_listens_on_loopback_only(view: ArmView):
    """The web port is bound to 127.0.0.1 alone, and so is the command socket."""
    assert view.url == f"http://127.0.0.1:{view.port}/static/"
    if not os.path.exists("/proc/net/tcp"):
        pytest.skip("no /proc/net/tcp to read listening sockets from")
    assert _listening_addresses(view.port) == ["0100007F"]  # 127.0.0.1, no IPv6, no 0.0.0.0
    zmq_port = int(view._server.zmq_url.rsplit(":", 1)[1])
    assert _listening_addresses(zmq_port) == ["0100007F"]


def test_view_page_is_served(view: ArmView):
    """The URL serves meshcat's viewer page."""
    with socket.create_connection(("127.0.0.1", view.port), timeout=5) as s:
        s.sendall(b"GET /static/ HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n")
        reply = b"".join(iter(lambda: s.recv(65536), b""))
    assert reply.startswith(b"HTTP/1.1 200")
    assert b"MeshCat" in reply


def _status(port: int, head: str) -> str:
    """The status line the server answers a raw request with."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(head.encode("latin-1") + b"\r\n")
        reply = s.recv(4096)
    return reply.split(b"\r\n", 1)[0].decode("latin-1")


UPGRADE = (
    "Upgrade: websocket\r\nConnection: Upgrade\r\n"
    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
)


@pytest.mark.parametrize(
    ("host", "origin"),
    [
        ("evil.example:{port}", None),  # DNS rebinding: the page's own name, our address
        ("evil.example", None),
        ("127.0.0.1.evil.example:{port}", None),
        ("localhost.:{port}", None),
        ("127.0.0.1:{other}", None),  # another port's name
        ("", None),
        ("127.0.0.1:{port}", "http://evil.example"),
        ("127.0.0.1:{port}", "http://evil.example:{port}"),
        ("127.0.0.1:{port}", "null"),
        ("127.0.0.1:{port}", "https://127.0.0.1:{port}"),
        ("127.0.0.1:{port}", "http://127.0.0.1:{other}"),
        ("127.0.0.1:{port}", "http://127.0.0.1"),  # port 80
        ("127.0.0.1:{port}", "http://user@127.0.0.1:{port}"),
    ],
)
@pytest.mark.parametrize("path", ["/static/", "/static/main.min.js", "/", "/nothing-here"])
@pytest.mark.heavy
def test_a_foreign_host_or_origin_gets_403(refusing_view: ArmView, host, origin, path):
    """Every page, file and 404 answers 403 to a Host or Origin that is not this server."""
    p, other = refusing_view.port, refusing_view.port + 1
    head = f"GET {path} HTTP/1.1\r\nHost: {host.format(port=p, other=other)}\r\n"
    if origin is not None:
        head += f"Origin: {origin.format(port=p, other=other)}\r\n"
    assert _status(p, head + "Connection: close\r\n") == "HTTP/1.1 403 Forbidden"


@pytest.mark.parametrize(
    ("host", "origin"),
    [
        ("evil.example:{port}", None),
        ("evil.example:{port}", "http://evil.example:{port}"),
        ("127.0.0.1:{port}", "http://evil.example"),
        ("localhost:{port}", "http://attacker.test:{port}"),
    ],
)
def test_a_foreign_websocket_upgrade_gets_403(refusing_view: ArmView, host, origin):
    p = refusing_view.port
    head = f"GET / HTTP/1.1\r\nHost: {host.format(port=p)}\r\n"
    if origin is not None:
        head += f"Origin: {origin.format(port=p)}\r\n"
    assert _status(p, head + UPGRADE) == "HTTP/1.1 403 Forbidden"
    assert refusing_view._server.browsers == 0


@pytest.mark.parametrize(
    ("host", "origin"),
    [
        ("127.0.0.1:{port}", "http://127.0.0.1:{port}"),
        ("localhost:{port}", "http://localhost:{port}"),
        ("[::1]:{port}", "http://[::1]:{port}"),
        ("LOCALHOST:{port}", None),
        ("127.0.0.1", None),
    ],
)
def test_the_loopback_names_are_served(view: ArmView, host, origin):
    """The page and the WebSocket answer requests for the loopback server."""
    p = view.port
    head = f"GET /static/ HTTP/1.1\r\nHost: {host.format(port=p)}\r\n"
    if origin is not None:
        head += f"Origin: {origin.format(port=p)}\r\n"
    assert _status(p, head + "Connection: close\r\n") == "HTTP/1.1 200 OK"
    upgrade = head.replace("/static/", "/", 1) + UPGRADE
    assert _status(p, upgrade) == "HTTP/1.1 101 Switching Protocols"


def test_port_in_use_is_a_named_error(view: ArmView, model: ArmModel):
    """Asking for a taken port raises ViewPortError naming it; nothing is left running."""
    with pytest.raises(ViewPortError, match=f"port {view.port} on 127.0.0.1") as err:
        ArmView(model, CONFIG, port=view.port)
    assert err.value.port == view.port


def test_close_frees_the_port_and_is_final(model: ArmModel):
    """close() stops the server (the port can be taken again), twice is fine, use after
    close is an error."""
    # a port of the kernel's choosing: the first free one from 7000 (the default) is what
    # every other view takes, and one of another xdist worker could take it in between
    v = ArmView(model, CONFIG, port=0)
    port = v.port
    v.close()
    v.close()
    assert v.closed
    assert _listening_addresses(port) == [] or not os.path.exists("/proc/net/tcp")
    with pytest.raises(ViewError, match="closed"):
        v.show_joints(model.home)
    with ArmView(model, CONFIG, port=port) as again:
        assert again.port == port


# --------------------------------------------------------------------------- static scene


def test_static_scene_has_table_bins_and_arm(view: ArmView):
    """The table's top is z = 0, each class's bin stands on it under its drop point in
    the class's colour, the arm is the URDF's visuals (every link and both jaws)."""
    tree = scene(view)
    table = tree["/meshcat/table"]
    size = table["object"]["geometries"][0]
    top = table["transform"][2, 3] + size["depth"] / 2
    assert top == pytest.approx(0.0, abs=1e-12)
    for c in CONFIG.task.classes:
        x, y, _z = c.bin_cm
        floor = tree[f"/meshcat/bins/{c.name}/floor"]
        assert floor["transform"][:2, 3] == pytest.approx([x / 100, y / 100])
        assert floor["transform"][2, 3] > 0
        assert object_color(floor) == rgb_int(c.draw_rgb)
    assert {b.split("/")[0] for b in drawn(view, "bins")} == set(CLASSES)  # one per class
    visuals = drawn(view, "arm/visuals")
    _, geom = urdf_visuals(view.model)
    assert visuals == {o.name for o in geom.geometryObjects}
    links = {f"link_{n}_0" for n in view.model.chain.names}
    jaws = {f"link_{n}_0" for n in jaw_joint_names(view.model.arm)}
    assert {"base_link_0"} | links | jaws <= visuals


def test_camera_looks_at_its_target(view: ArmView):
    """The scene is shifted by −target and the camera sits at position − target, in
    three.js's y-up axes."""
    cam = view.camera
    assert cam == view.layout.camera
    tree = scene(view)
    shift = tree["/meshcat"]["transform"][:3, 3]
    assert shift == pytest.approx(-np.array(cam.target_cm) / 100)
    props = tree["/Cameras/default/rotated/<object>"]["properties"]
    rel = (np.array(cam.position_cm) - cam.target_cm) / 100
    assert props["position"] == pytest.approx([rel[0], rel[2], -rel[1]])
    assert props["fov"] == cam.fov_deg


def test_framing_keeps_every_point_in_view():
    """The framing camera looks at the points' box centre and projects each point inside
    the view."""
    rng = np.random.default_rng(0)
    points = rng.uniform([-30, -10, 0], [30, 60, 40], size=(50, 3))
    cam = ViewCamera.framing(points)
    lo, hi = points.min(axis=0), points.max(axis=0)
    assert cam.target_cm == pytest.approx((lo + hi) / 2)
    uv = cam.project(points, W, H)
    assert (uv >= 0).all() and (uv[:, 0] <= W).all() and (uv[:, 1] <= H).all()


def test_camera_projection_basics():
    """The target projects to the view's centre, points behind the camera to NaN, and
    +x (towards the camera's right here) moves a point right."""
    cam = ViewCamera((0.0, -100.0, 50.0), (0.0, 0.0, 0.0), 40.0)
    uv = cam.project([[0, 0, 0], [10, 0, 0], [0, -200, 0]], 800, 600)
    assert uv[0] == pytest.approx([400, 300])
    assert uv[1, 0] > 400
    assert np.isnan(uv[2]).all()
    with pytest.raises(ViewInputError, match="straight above"):
        ViewCamera((0, 0, 100), (0, 0, 0))
    with pytest.raises(ViewInputError, match="fov_deg"):
        ViewCamera((0, -1, 1), (0, 0, 0), fov_deg=0.5)


# --------------------------------------------------------------------------- arm


def assert_arm_drawn_at(view: ArmView, q: np.ndarray, opening_cm: float) -> None:
    """Every arm visual, jaws included, sits where Pinocchio puts it for q and the opening."""
    full, geom = urdf_visuals(view.model)
    gdata = geom.createData()
    data = full.createData()
    pin.forwardKinematics(full, data, urdf_q(full, view.model, q, opening_cm))
    pin.updateGeometryPlacements(full, data, geom, gdata)
    tree = scene(view)
    for i, obj in enumerate(geom.geometryObjects):
        shown = tree[f"/meshcat/arm/visuals/{obj.name}"]["transform"]
        assert shown == pytest.approx(gdata.oMg[i].homogeneous, abs=1e-9), obj.name


def test_show_joints_places_the_urdf_geometry(view: ArmView, model: ArmModel):
    """After show_joints(q) every arm visual sits where Pinocchio puts it for q; the
    actuated joints alone get the passive ones from the coupling."""
    chain = model.chain
    q_act = np.radians([70.0, 60.0, -100.0])
    view.show_joints(q_act)
    q = chain.full(q_act)
    assert view.joints == pytest.approx(q)
    assert_arm_drawn_at(view, q, CONFIG.arm.tool.gripper.open_cm)
    view.show_joints(model.home)
    assert view.joints == pytest.approx(model.home)


def test_jaws_open_and_close(view: ArmView, model: ArmModel):
    """The opening moves the jaws' inner faces apart by it, along one axis."""
    left, right = (f"/meshcat/arm/visuals/link_{n}_0" for n in jaw_joint_names(model.arm))
    gaps = {}
    for opening in (1.0, 3.0):
        view.show_joints(model.home, opening)
        tree = scene(view)
        gaps[opening] = tree[left]["transform"][:3, 3] - tree[right]["transform"][:3, 3]
        # the jaws' inner faces are the opening apart, so their centres one thickness more
        thick = model.arm.tool.gripper.jaw_thickness_cm
        assert np.linalg.norm(gaps[opening]) == pytest.approx((opening + thick) / 100)
        assert_arm_drawn_at(view, model.home, opening)
    assert np.cross(gaps[1.0], gaps[3.0]) == pytest.approx(np.zeros(3), abs=1e-12)
    view.show_joints(model.home)
    assert view.opening_cm == 3.0


@pytest.mark.parametrize("bad", [[1.0, 2.0], [0.0, 0.0, float("nan")], "abc", np.zeros((2, 4))])
def test_show_joints_rejects_bad_input(view: ArmView, bad):
    with pytest.raises(ViewInputError, match="q") as err:
        view.show_joints(bad)
    assert err.value.argument == "q"
    assert "3 or 4 finite joint values in model units" in str(err.value)
    assert "base, shoulder, elbow, wrist" in str(err.value)


def test_show_joints_rejects_a_bad_opening(view: ArmView, model: ArmModel):
    with pytest.raises(ViewInputError, match="opening_cm"):
        view.show_joints(model.home, float("nan"))


# --------------------------------------------------------------------------- objects


def test_objects_are_added_moved_recoloured_and_removed(view: ArmView):
    """set_objects leaves exactly the listed objects on the server, each at its place,
    standing on the table, in its class's colour and size."""
    world = World.from_config(CONFIG)
    view.set_objects(world.objects)
    assert drawn(view, "objects") == {o.id for o in world.objects}
    tree = scene(view)
    for o in world.objects:
        node = tree[f"/meshcat/objects/{o.id}"]
        c = CLASSES[o.color]
        z = c.height_cm / 200
        assert node["transform"][:3, 3] == pytest.approx([o.x_cm / 100, o.y_cm / 100, z])
        assert node["transform"][:3, 1] == pytest.approx([0, 0, 1])  # cylinder axis up
        assert object_color(node) == rgb_int(c.draw_rgb)
        cylinder = node["object"]["geometries"][0]
        assert cylinder["height"] == pytest.approx(c.height_cm / 100)
        assert cylinder["radiusTop"] == pytest.approx(c.diameter_cm / 200)

    # red1 moves, green1 turns blue, blue4 is new, everything else but red2 disappears
    view.set_objects(
        [
            ("red1", "red", 1.0, 40.0),
            ("red2", "red", world.objects[1].x_cm, world.objects[1].y_cm),
            ("green1", "blue", -8.31, 53.81),
            ("blue9", "blue", 5.0, 30.0),
        ]
    )
    assert drawn(view, "objects") == {"red1", "red2", "green1", "blue9"}
    assert set(view.objects) == {"red1", "red2", "green1", "blue9"}
    tree = scene(view)
    assert tree["/meshcat/objects/red1"]["transform"][:2, 3] == pytest.approx([0.01, 0.40])
    assert object_color(tree["/meshcat/objects/green1"]) == rgb_int(CLASSES["blue"].draw_rgb)
    view.set_objects([])
    assert drawn(view, "objects") == set()


@pytest.mark.parametrize(
    ("objects", "match"),
    [
        ([("a", "purple", 0, 40)], "class of a = 'purple'.*red, green, blue"),
        ([("a", "red", 0, 40), ("a", "blue", 1, 40)], "each id at most once"),
        ([("a/b", "red", 0, 40)], "without '/'"),
        ([("a", "red", float("nan"), 40)], "finite x_cm, y_cm"),
        ([("a", "red", 0)], r"\(id, class_name, x_cm, y_cm\)"),
    ],
)
def test_bad_objects_are_refused_and_change_nothing(view: ArmView, objects, match):
    view.set_objects([("keep", "green", 0.0, 45.0)])
    with pytest.raises(ViewInputError, match=match):
        view.set_objects(objects)
    assert drawn(view, "objects") == {"keep"}


# --------------------------------------------------------------------------- camera frame


def test_frame_plane_with_the_paper_calibration_is_the_frame_itself():
    """With the paper's axis-aligned calibration (0.0625 cm/px) the texture at 16 px/cm is
    the frame pixel for pixel, and its corners are the image's outer edges."""
    frame = SimCamera(CONFIG, World.from_config(CONFIG)).read()
    plane = frame_plane(frame, CAL.pixel_to_table)
    expected = [
        [-20.53125, 59.03125],
        [19.46875, 59.03125],
        [19.46875, 29.03125],
        [-20.53125, 29.03125],
    ]
    assert plane.corners_cm == pytest.approx(np.array(expected))
    assert plane.texture_bgra.shape == (480, 640, 4)
    assert np.abs(plane.texture_bgra[:, :, :3].astype(int) - frame).max() <= 1
    assert (plane.texture_bgra[:, :, 3] == 255).all()


def test_frame_plane_puts_every_pixel_where_the_calibration_maps_it():
    """Under a perspective calibration, marks drawn in the frame land in the texture at
    pixel_to_table(mark); outside the image's outline the texture is transparent."""
    pixels = np.array([[0, 0], [640, 0], [640, 480], [0, 480]], float)
    table = np.array([[-18, 60], [22, 56], [17, 28], [-22, 32]], float)  # a tilted, skewed field
    cal = Calibration.fit(pixels, table)
    frame = np.full((480, 640, 3), 128, np.uint8)
    marks = {(100, 80): (0, 0, 255), (500, 120): (0, 255, 0), (320, 400): (255, 0, 0)}
    for (u, v), bgr in marks.items():
        cv2.circle(frame, (u, v), 6, bgr, -1)
    plane = frame_plane(frame, cal.pixel_to_table)
    for (u, v), bgr in marks.items():
        c, r = np.round(plane.table_to_texture(cal.pixel_to_table([[u, v]]))[0]).astype(int)
        assert tuple(plane.texture_bgra[r, c, :3]) == pytest.approx(bgr, abs=10), (u, v)
    assert plane.texture_bgra[0, 0, 3] == 0  # the bounding box's corner is off the image
    assert (
        plane.texture_bgra[plane.texture_bgra.shape[0] // 2, plane.texture_bgra.shape[1] // 2, 3]
        == 255
    )


@pytest.mark.parametrize(
    ("frame", "p2t", "match"),
    [
        (np.zeros((48, 64, 3), np.float32), CAL.pixel_to_table, "8-bit"),
        (np.zeros((48, 64, 4), np.uint8), CAL.pixel_to_table, r"\(H, W, 3\)"),
        (np.zeros((48, 64, 3), np.uint8), lambda px: px[:, :1], r"4 finite \(x, y\) points"),
        (np.zeros((48, 64, 3), np.uint8), lambda px: 1 / 0, "it raised division by zero"),
        (np.zeros((48, 64, 3), np.uint8), lambda px: px[[0, 2, 1, 3]], "convex quadrilateral"),
        (np.zeros((48, 64, 3), np.uint8), lambda px: px * 0, "convex quadrilateral"),
    ],
)
def test_frame_plane_rejects_bad_frames_and_calibrations(frame, p2t, match):
    with pytest.raises(ViewInputError, match=match):
        frame_plane(frame, p2t)


@pytest.mark.heavy
def test_set_camera_frame_lays_the_texture_on_the_table(view: ArmView):
    """The plane lies just above the table top, centred and sized as the frame's outline."""
    frame = SimCamera(CONFIG, World.from_config(CONFIG)).read()
    view.set_camera_frame(frame, CAL.pixel_to_table)
    assert isinstance(view.frame_plane, FramePlane)
    node = scene(view)["/meshcat/camera_frame"]
    geometry = node["object"]["geometries"][0]
    assert geometry["type"] == "PlaneGeometry"
    assert [geometry["width"], geometry["height"]] == pytest.approx([0.40, 0.30])
    assert node["transform"][:3, 3] == pytest.approx([-0.0053125, 0.4403125, 0.0005])
    assert node["object"]["images"][0]["url"].startswith("data:image/png;base64,")
    view.clear_camera_frame()
    assert "object" not in scene(view).get("/meshcat/camera_frame", {})


# --------------------------------------------------------------------------- target, paths


def test_target_marker_appears_moves_and_goes(view: ArmView):
    view.set_target((-20.0, 35.0, 20.0))
    view.set_target([1.0, 50.0, 12.76])
    node = scene(view)["/meshcat/target"]
    assert node["transform"][:3, 3] == pytest.approx([0.01, 0.50, 0.1276])
    view.set_target(None)
    assert "object" not in scene(view).get("/meshcat/target", {})
    with pytest.raises(ViewInputError, match="target_cm"):
        view.set_target((1.0, 2.0))


def test_paths_accumulate_until_cleared(view: ArmView):
    """Each add_path adds a line holding the route's points; clear_paths removes all."""
    first = np.array([[-20.16, 34.91, 19.95], [-10.0, 45.0, 15.0], [-0.75, 53.72, 12.76]])
    assert view.add_path(first, "#c81e23") == "route1"
    assert view.add_path(first[::-1] + 1.0, 0x123456) == "route2"
    assert view.paths == ["route1", "route2"]
    tree = scene(view)
    assert drawn(view, "paths") == {"route1", "route2"}
    line = tree["/meshcat/paths/route1"]["object"]
    assert line["object"]["type"] == "Line"
    stored = line["geometries"][0]["data"]["attributes"]["position"]
    points = np.frombuffer(stored["array"].data, np.float32).reshape(-1, 3)
    assert points == pytest.approx(first / 100, abs=1e-6)
    assert object_color(tree["/meshcat/paths/route2"]) == 0x123456
    view.clear_paths()
    assert view.paths == []
    assert drawn(view, "paths") == set()
    assert view.add_path(first) == "route1"


@pytest.mark.parametrize(
    ("points", "color", "match"),
    [
        ([[0, 0, 0]], "#c81e23", "N >= 2"),
        ([[0, 0], [1, 1]], "#c81e23", "shape"),
        ([[0, 0, 0], [1, float("inf"), 1]], "#c81e23", "finite"),
        ([[0, 0, 0], [1, 1, 1]], "chartreuse", "color = 'chartreuse'"),
        ([[0, 0, 0], [1, 1, 1]], "#12345", "#RRGGBB"),
        ([[0, 0, 0], [1, 1, 1]], 0x1000000, "0xRRGGBB"),
    ],
)
def test_add_path_rejects_bad_input(view: ArmView, points, color, match):
    with pytest.raises(ViewInputError, match=match):
        view.add_path(points, color)
    assert view.paths == []


# --------------------------------------------------------------------------- browser


def test_no_browser_is_a_named_error(monkeypatch, tmp_path):
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("MEARM_CHROMIUM", raising=False)
    with pytest.raises(BrowserNotFoundError, match="apt-get install chromium") as err:
        find_browser()
    assert "chromium" in err.value.candidates


def test_screenshot_checks_its_arguments(tmp_path):
    (tmp_path / "no").write_text("a file")
    with pytest.raises(ViewInputError, match="not under a file"):
        screenshot("http://127.0.0.1:1/", tmp_path / "no" / "x" / "y.png", browser="unused")
    with pytest.raises(ViewInputError, match="width_px"):
        screenshot("http://127.0.0.1:1/", tmp_path / "x.png", width_px=4, browser="unused")


def exit_of(action: Callable[[], object], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """What a command that does ``action`` exits with under mearm's guard, and its stderr."""

    def main(argv: object) -> int:
        action()
        return 0

    with pytest.raises(SystemExit) as exit_:
        run(main, [])
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return exit_.value.code, err


def test_no_browser_or_one_that_cannot_be_run_is_bad_input(monkeypatch, tmp_path, capsys):
    """What the environment lacks before any work (no browser installed, a "browser" that
    is not an executable) is exit 2, as a missing camera is."""
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("MEARM_CHROMIUM", raising=False)
    shoot = partial(screenshot, "http://127.0.0.1:1/", tmp_path / "x.png")
    code, err = exit_of(shoot, capsys)
    assert code == 2 and "no headless browser found" in err
    text = tmp_path / "browser.txt"
    text.write_text("not a program\n")
    code, err = exit_of(partial(shoot, browser=str(text)), capsys)
    assert code == 2 and f"cannot run {text}: " in err


def test_a_browser_that_exits_at_start_is_a_failure_of_the_run(tmp_path, capsys):
    """A browser that runs but quits before it is ready fails the run: exit 1, not 2."""
    false = shutil.which("false")
    assert false is not None
    shoot = partial(screenshot, "http://127.0.0.1:1/", tmp_path / "x.png", browser=false)
    code, err = exit_of(shoot, capsys)
    assert code == 1 and "the browser exited (1) before it was ready" in err
    assert not (tmp_path / "x.png").exists()


def test_a_view_server_that_does_not_answer_is_a_failure_of_the_run(capsys):
    """A command the meshcat server does not answer within its timeout fails the run
    (exit 1) naming the server, instead of blocking forever."""
    server = MeshcatServer(port=0, timeout_s=0.5)
    window = server.window()
    try:
        server.close()
        vis = meshcat.Visualizer(window=window)
        code, err = exit_of(vis["table"].delete, capsys)
    finally:
        window.close()
    assert code == 1
    assert f"the meshcat server at {server.web_url} did not answer within 0.5 s" in err


@pytest.mark.heavy
def test_a_png_the_disk_has_no_room_for_fails_the_run(
    view: ArmView, chromium: HeadlessBrowser, capsys
):
    """The picture was drawn, the disk is full (/dev/full): exit 1, not bad input."""
    full = Path("/dev/full")
    if not full.exists():
        pytest.skip("no /dev/full")
    shoot = partial(view.screenshot, full, width_px=64, height_px=64, session=chromium)
    code, err = exit_of(shoot, capsys)
    assert code == 1 and "cannot write /dev/full: No space left on device" in err


@pytest.mark.heavy
def test_an_address_the_browser_cannot_load_is_bad_input(tmp_path, chromium, capsys):
    """The browser refusing the url it was given is the caller's error: exit 2."""
    code, err = exit_of(
        partial(screenshot, "not a url", tmp_path / "x.png", session=chromium), capsys
    )
    assert code == 2 and "Page.navigate failed: Cannot navigate to invalid URL" in err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.heavy
def test_a_running_browser_closes_the_tab_it_drew_in(
    view: ArmView, tmp_path, chromium: HeadlessBrowser
):
    """A picture drawn in a running browser shows the arm and leaves no tab behind."""
    port = int(chromium._ws_url.split(":")[2].split("/")[0])

    def pages() -> list[dict]:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
            return [t for t in json.loads(r.read()) if t["type"] == "page"]

    before = len(pages())
    png = view.screenshot(tmp_path / "a.png", width_px=W, height_px=H, session=chromium)
    img = cv2.imread(str(png))
    assert img.shape == (H, W, 3)
    assert hsv_mask(img, "orange").sum() > 300
    assert len(pages()) == before


def test_a_closed_browser_has_ended_and_left_no_profile(tmp_path):
    """Closing a running browser ends its process and removes its profile; it draws no more."""
    running = HeadlessBrowser(browser_or_skip())
    proc, profile = running._proc, Path(running._profile.name)
    assert proc is not None and proc.poll() is None and profile.is_dir()
    running.close()
    running.close()
    assert proc.poll() is not None and not profile.exists()
    with pytest.raises(ViewError, match="closed"):
        screenshot("http://127.0.0.1:1/", tmp_path / "x.png", session=running)


@pytest.mark.heavy
def test_render_shows_the_arm_and_objects_where_they_are(
    model: ArmModel, tmp_path, chromium: HeadlessBrowser
):
    """In Chromium's render of the arm at home, the 12 paper objects, the bins, the
    target and the camera frame, each thing's colour is at its projected place."""
    world = World.from_config(CONFIG)
    frame = SimCamera(CONFIG, world).read()
    target_cm = np.array([12.0, 30.0, 12.76])
    with ArmView(model, CONFIG) as v:
        v.set_objects(world.objects)
        v.set_camera_frame(frame, CAL.pixel_to_table)
        v.set_target(target_cm)
        png = v.screenshot(tmp_path / "view.png", width_px=W, height_px=H, session=chromium)
        cam = v.camera
    img = cv2.imread(str(png))
    assert img.shape == (H, W, 3)

    # every object: its colour at its projected centre, and one blob of it right there
    for color in ("red", "green", "blue"):
        mask = hsv_mask(img, color)
        n, _, stats, centroids = cv2.connectedComponentsWithStats(mask.astype(np.uint8))
        objects = [o for o in world.objects if o.color == color]
        expected = cam.project([[o.x_cm, o.y_cm, 0.5] for o in objects], W, H)
        for o, uv in zip(objects, expected, strict=True):
            assert fraction(mask, uv) > 0.9, f"{o.id} not {color} at {uv.round()}"
            d = np.linalg.norm(centroids[1:] - uv, axis=1)
            k = int(np.argmin(d))
            assert d[k] < 4.0, f"{o.id}: nearest {color} blob {d[k]:.1f} px away"
            assert 30 <= stats[1 + k, cv2.CC_STAT_AREA] <= 600, o.id
        # blob centroids ordered as the layout is, left to right and top to bottom
        blobs = np.array(
            [
                centroids[1:][np.argmin(np.linalg.norm(centroids[1:] - uv, axis=1))]
                for uv in expected
            ]
        )
        assert list(np.argsort(blobs[:, 0])) == list(np.argsort(expected[:, 0]))
        assert list(np.argsort(blobs[:, 1])) == list(np.argsort(expected[:, 1]))

    # the arm: orange along links 2 and 3 (joint origins from Pinocchio at home)
    orange = hsv_mask(img, "orange")
    data = model.model.createData()
    pin.forwardKinematics(model.model, data, model.home)
    joints = [data.oMi[i].translation * 100 for i in (2, 3, 4)]
    for a, b in ((0, 1), (1, 2)):
        for t in (0.3, 0.5, 0.7):
            uv = cam.project(joints[a] * (1 - t) + joints[b] * t, W, H)[0]
            assert fraction(orange, uv) > 0.9, f"no arm at link {a + 2}, t={t}: {uv.round()}"

    # the bins' floors in their colour, the target in yellow
    for c in CONFIG.task.classes:
        x, y, _z = c.bin_cm
        uv = cam.project([x, y, 0.4], W, H)[0]
        assert fraction(hsv_mask(img, c.name), uv) > 0.9, f"{c.name} bin"
    assert fraction(hsv_mask(img, "yellow"), cam.project(target_cm, W, H)[0], 1) > 0.9

    # the camera frame: the texture's own colour where it lies; the bare table elsewhere
    plane = frame_plane(frame, CAL.pixel_to_table)
    for xy in ([15.0, 32.0], [-8.0, 31.0], [16.0, 57.0]):
        uv = cam.project([*xy, 0.05], W, H)[0]
        c, r = np.round(plane.table_to_texture(xy)[0]).astype(int)
        tex = plane.texture_bgra[r - 8 : r + 9, c - 8 : c + 9, :3].reshape(-1, 3).mean(axis=0)
        u, v = np.round(uv).astype(int)
        shown = img[v - 1 : v + 2, u - 1 : u + 2].reshape(-1, 3).mean(axis=0)
        assert np.abs(shown - tex).max() < 25, (xy, shown, tex)
    u, v = np.round(cam.project([30.0, 10.0, 0.0], W, H)[0]).astype(int)
    table = cv2.cvtColor(img[v : v + 1, u : u + 1], cv2.COLOR_BGR2HSV)[0, 0]
    assert table[1] < 40, "the bare table is grey"


# --------------------------------------------------------------------------- preview CLI


def _load_preview():
    return importlib.import_module("mearm.tools.preview")


PREVIEW = _load_preview()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--joints", "shoulder=20"], "shoulder = 20 deg is outside its limits [30, 135] deg"),
        (["--joints", "120,93"], "--joints must be NAME=VALUE pairs"),
        (["--joints", "hip=3"], "unknown joint(s) 'hip'; this arm's actuated joints: base, "),
        (["--sweep", "wrist"], "unknown joint 'wrist'; this arm's actuated joints: base, "),
        (
            ["--config", "configs/sim_5dof.yaml", "--sweep", "base"],
            "actuated joints: base_yaw, shoulder, elbow, wrist_pitch, wrist_roll",
        ),
        (["--set", "arm.joints.shoulder.home=20"], "home"),
        (["--size", "10x10"], "--size sides must be in [16, 8192] px"),
        (["--step-deg", "0"], "must be a positive number, got '0'"),
        (["--port", "70000"], "port 70000 on 127.0.0.1"),
    ],
)
def test_preview_refuses_bad_arguments_in_one_line(args, message, capsys):
    """Bad input ends with exit 2 and one line on stderr, before anything is served."""
    with pytest.raises(SystemExit) as exit_:
        run(PREVIEW.main, args)
    assert exit_.value.code == 2
    out, err = capsys.readouterr()
    assert message in err
    assert len(err.strip().splitlines()) == 1
    assert out == ""


def test_sweep_poses_cover_each_joint_range_in_small_steps():
    """The sweep visits both limits of each chosen joint, never leaves them, moves one
    joint at a time by at most the step, and ends at the start."""
    openings = list(PREVIEW.sweep_openings_cm(4.0, 1.0, 0.5))
    assert min(openings) == 1.0 and openings[-1] == 4.0
    assert (np.abs(np.diff([4.0, *openings])) <= 0.5 + 1e-9).all()
    start, lower, upper = [120.0, 93.0, -132.0], [20.0, 30.0, -160.0], [160.0, 135.0, -20.0]
    poses = np.array(list(PREVIEW.sweep_poses_deg(start, lower, upper, [0, 2], 1.5)))
    path = np.vstack([start, poses])
    steps = np.abs(np.diff(path, axis=0))
    assert (steps <= 1.5 + 1e-9).all()
    assert ((steps > 0).sum(axis=1) <= 1).all()
    assert poses[:, 0].min() == 20.0 and poses[:, 0].max() == 160.0
    assert poses[:, 2].min() == -160.0 and poses[:, 2].max() == -20.0
    assert (poses[:, 1] == 93.0).all()
    assert poses[-1] == pytest.approx(start)


@pytest.mark.heavy
def test_preview_serves_until_ctrl_c():
    """The tool prints a 127.0.0.1 URL, keeps serving, and exits 130 without a traceback
    on SIGINT."""
    proc = subprocess.Popen(
        [sys.executable, "tools/preview.py", "--sweep", "base", "--port", "0"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)/static/", line)
        assert match, line
        with socket.create_connection(("127.0.0.1", int(match.group(1))), timeout=5):
            pass
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=15)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert err.strip().endswith(": interrupted")
    assert len(err.strip().splitlines()) == 1


@pytest.mark.heavy
def test_preview_screenshot_renders_the_arm(tmp_path, capsys):
    """--screenshot writes a PNG showing the arm (orange) at the named joints and exits 0.
    In this process (its own Chromium, as the user's command starts one);
    ``test_preview_serves_until_ctrl_c`` runs the tool as a process."""
    browser_or_skip()
    out = tmp_path / "arm.png"
    args = ["--joints", "base=90,shoulder=60,elbow=-100", "--screenshot", str(out)]
    with pytest.raises(SystemExit) as exit_:
        run(PREVIEW.main, [*args, "--size", f"{W}x{H}"])
    assert exit_.value.code == 0
    assert f"wrote {out}" in capsys.readouterr().out
    img = cv2.imread(str(out))
    assert img.shape == (H, W, 3)
    model = ArmModel(CONFIG.arm)
    q = model.chain.from_named({"base": 90.0, "shoulder": 60.0, "elbow": -100.0})
    data = model.model.createData()
    pin.forwardKinematics(model.model, data, q)
    middle_of_link3 = (data.oMi[3].translation + data.oMi[4].translation) / 2 * 100
    uv = SceneLayout.of(model, CONFIG).camera.project(middle_of_link3, W, H)[0]
    assert fraction(hsv_mask(img, "orange"), uv) > 0.9


# --------------------------------------------------------------------------- any arm


@pytest.fixture(scope="module", params=REFERENCE_CONFIGS)
def reference(request: pytest.FixtureRequest) -> tuple[str, Config, ArmModel]:
    config = load_config(ROOT / "configs" / request.param)
    return request.param, config, ArmModel(config.arm)


def test_each_reference_arm_is_drawn_with_its_links_jaws_and_classes(reference):
    """Every link and both jaws of each reference arm are in the scene tree where
    Pinocchio puts them at home; one bin per class; the objects in their class colours."""
    _, config, model = reference
    with ArmView(model, config, port=0) as v:
        v.set_objects(World.from_config(config).objects)
        visuals = drawn(v, "arm/visuals")
        for name in model.chain.names:
            assert f"link_{name}_0" in visuals, name
        for jaw in jaw_joint_names(model.arm):
            assert f"link_{jaw}_0" in visuals, jaw
        assert_arm_drawn_at(v, model.home, config.arm.tool.gripper.open_cm)
        tree = scene(v)
        for c in config.task.classes:
            assert object_color(tree[f"/meshcat/bins/{c.name}/floor"]) == rgb_int(c.draw_rgb)
        for o in config.task.scene:
            assert o.color in config.task.class_names
        colors = {object_color(tree[f"/meshcat/objects/{o}"]) for o in drawn(v, "objects")}
        assert colors == {
            rgb_int(c.draw_rgb)
            for c in config.task.classes
            if any(o.color == c.name for o in config.task.scene)
        }
        v.show_joints(model.home, config.arm.tool.gripper.closed_cm)
        assert_arm_drawn_at(v, model.home, config.arm.tool.gripper.closed_cm)


def test_each_reference_layout_holds_the_bins_on_the_table(reference):
    """The table holds the base, every bin's whole footprint (the collision model's outer
    width) and every object."""
    _, config, model = reference
    layout = SceneLayout.of(model, config)
    bins = np.array([c.bin_cm[:2] for c in config.task.classes])
    half = np.array([[bin_half_outer_m(c) * 100] for c in config.task.classes])
    xy = np.vstack([[0.0, 0.0], bins - half, bins + half, [[o.x, o.y] for o in config.task.scene]])
    (x0, x1), (y0, y1) = layout.table_x_cm, layout.table_y_cm
    assert (xy[:, 0] > x0).all() and (xy[:, 0] < x1).all()
    assert (xy[:, 1] > y0).all() and (xy[:, 1] < y1).all()


@pytest.mark.heavy
def test_each_reference_arm_renders(reference, tmp_path, chromium: HeadlessBrowser):
    """A render of each reference arm at home with its scene is not empty: the arm's
    orange shows along its links, and the whole arm is inside the picture."""
    name, config, model = reference
    with ArmView(model, config, port=0) as v:
        v.set_objects(World.from_config(config).objects)
        png = v.screenshot(tmp_path / "view.png", width_px=W, height_px=H, session=chromium)
        cam = v.camera
    img = cv2.imread(str(png))
    assert img.shape == (H, W, 3)
    assert img.reshape(-1, 3).std(axis=0).max() > 10, f"{name}: a blank picture"
    orange = hsv_mask(img, "orange")
    assert orange.sum() > 300, f"{name}: no arm ({orange.sum()} orange px)"
    data = model.model.createData()
    pin.forwardKinematics(model.model, data, model.home)
    points = np.array([data.oMi[i].translation * 100 for i in range(1, model.model.njoints)])
    uv = cam.project(np.vstack([points, model.fk_cm(model.home)]), W, H)
    assert (uv > 0).all() and (uv[:, 0] < W).all() and (uv[:, 1] < H).all(), name
