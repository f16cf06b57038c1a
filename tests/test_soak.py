"""Long runs in one process: nothing grows that should stay flat.

300 kinematic sorts and 50 sorts in the physical twin, each a whole ``mearm sort`` run
in this process with its run log; then the meshcat server serving 20 clients that
connect, take the scene and leave, over and over, for 60 s. Resident memory may grow by
less than :data:`MAX_RSS_GROWTH_MB` after a warm-up; open file descriptors and threads
must come back to where they were.

Not part of ``make test`` (a few minutes): ``make soak`` runs it, or ``pytest -m soak``;
each test prints what it measured.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import io
import os
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
import tornado.websocket
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sort import main as sort_main

pytestmark = pytest.mark.soak

#: Resident memory a long run may gain after its warm-up [MB].
MAX_RSS_GROWTH_MB = 50.0
#: Runs (or seconds of clients) before the baseline is taken: caches fill, imports land.
WARM_UP_SORTS = 10
WARM_UP_S = 5.0


@dataclass(frozen=True)
class Usage:
    """What the process holds: resident memory [MB], open file descriptors, threads."""

    rss_mb: float
    fds: int
    threads: int

    @classmethod
    def now(cls) -> Usage:
        """This process's usage, from /proc (after a garbage collection)."""
        gc.collect()
        fields = {}
        for line in Path("/proc/self/status").read_text().splitlines():
            key, _, value = line.partition(":")
            fields[key] = value.split()
        return cls(
            int(fields["VmRSS"][0]) / 1024,
            len(os.listdir("/proc/self/fd")),
            int(fields["Threads"][0]),
        )


def _check_flat(what: str, base: Usage, end: Usage, peak_mb: float) -> None:
    print(
        f"\n{what}: RSS {base.rss_mb:.1f} -> {end.rss_mb:.1f} MB (peak {peak_mb:.1f}, growth "
        f"{end.rss_mb - base.rss_mb:+.1f} MB), fds {base.fds} -> {end.fds}, threads "
        f"{base.threads} -> {end.threads}"
    )
    assert end.rss_mb - base.rss_mb < MAX_RSS_GROWTH_MB
    assert end.fds <= base.fds
    assert end.threads <= base.threads


def _soak_sorts(n: int, args: list[str], log: Path) -> None:
    """``n`` sorts of random scenes (seed i), each a whole run with its log."""
    codes: dict[int, int] = {}
    base = None
    peak = 0.0
    for i in range(n):
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            code = sort_main([*args, "--seed", str(i), "--log", str(log), "--quiet"])
        codes[code] = codes.get(code, 0) + 1
        usage = Usage.now()
        peak = max(peak, usage.rss_mb)
        if i + 1 == WARM_UP_SORTS:
            base = usage
    assert set(codes) <= {0, 1}, codes  # sorted, or left some with a reason: never a crash
    assert codes.get(0, 0) >= n // 2, codes
    assert base is not None
    _check_flat(f"{n} sorts {' '.join(args)} (exit codes {codes})", base, Usage.now(), peak)


def test_300_kinematic_sorts_leak_nothing(tmp_path):
    """300 sorts of 6 random objects in the kinematic simulator."""
    _soak_sorts(300, ["--random", "6"], tmp_path / "kinematic.jsonl")


def test_50_twin_sorts_leak_nothing(tmp_path):
    """50 sorts of 2 random objects in the physical twin (a MuJoCo model, its physics and
    an offscreen GL renderer each)."""
    config = str(ROOT / "configs" / "sim_mujoco.yaml")
    _soak_sorts(50, ["--config", config, "--random", "2"], tmp_path / "twin.jsonl")


async def _client(url: str, messages: int, deadline: float, counts: list[int]) -> None:
    """Connect, take the whole scene, leave; again until the deadline."""
    while time.monotonic() < deadline:
        conn = await tornado.websocket.websocket_connect(url, max_message_size=64 * 2**20)
        try:
            for _ in range(messages):
                if await conn.read_message() is None:
                    raise AssertionError("the server closed a client before its scene")
        finally:
            conn.close()
            # until the server's close frame: a socket left half closed stays open here
            while await asyncio.wait_for(conn.read_message(), 10) is not None:
                pass
        counts[0] += 1


async def _clients(view, model: ArmModel, seconds: float, n: int = 20) -> int:
    """``n`` clients coming and going for ``seconds`` while the arm moves; visits made."""
    messages = view._server.scene_counts().messages  # what a new client is sent
    url = f"ws://127.0.0.1:{view.port}/"
    counts = [0]
    deadline = time.monotonic() + seconds
    tasks = [asyncio.create_task(_client(url, messages, deadline, counts)) for _ in range(n)]
    k = 0
    while time.monotonic() < deadline:  # the scene changes meanwhile, as in a sort
        q = model.home.copy()
        q[0] += 10.0 * ((k % 20) / 20)
        view.show_joints(q)
        k += 1
        await asyncio.sleep(0.2)
    await asyncio.gather(*tasks)
    return counts[0]


def _settled(view) -> Usage:
    """The usage once the server has let every client go (it closes them on its thread)."""
    deadline = time.monotonic() + 10
    while view.browsers and time.monotonic() < deadline:
        time.sleep(0.05)
    assert view.browsers == 0
    time.sleep(0.2)  # the last sockets' own clean-up on the server's loop
    return Usage.now()


def test_the_meshcat_server_serves_20_clients_for_a_minute_without_a_leak():
    """20 clients connect, take the scene and leave, over and over for 60 s."""
    from mearm.view import ArmView

    config = load_config(None)
    model = ArmModel(config.arm)
    view = ArmView(model, config)
    try:
        asyncio.run(_clients(view, model, WARM_UP_S))
        base, peak = _settled(view), 0.0
        visits = 0
        for _ in range(6):
            visits += asyncio.run(_clients(view, model, 10.0))
            peak = max(peak, Usage.now().rss_mb)
        end = _settled(view)
        _check_flat(f"meshcat server, 20 clients, {visits} visits in 60 s", base, end, peak)
    finally:
        view.close()
