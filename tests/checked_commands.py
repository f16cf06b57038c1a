"""A watch on the executor: which streamed routes were sent as checked commands.

Between two commands the servos move on the chord between them, a little off a planned
route where it turns; whatever streams a route must have its commands themselves checked
for collisions (:meth:`Executor.followed <mearm.task.execute.Executor.followed>`). The
watch records every path the collision model checked and the commands each
:meth:`Executor.stream <mearm.task.execute.Executor.stream>` sent; the real methods run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from mearm.kinematics.collision import CollisionModel
from mearm.task.execute import Executor


@dataclass
class StreamWatch:
    """Each path checked (but its first pose: where it starts) and each route's commands."""

    checked: set[bytes] = field(default_factory=set)
    streamed: list[np.ndarray] = field(default_factory=list)
    _sending: list[list[np.ndarray]] = field(default_factory=list)

    def unchecked(self) -> list[int]:
        """The streamed routes (indices) whose commands no check looked at."""
        return [k for k, q in enumerate(self.streamed) if q.tobytes() not in self.checked]


def watch_streams(monkeypatch: pytest.MonkeyPatch) -> StreamWatch:
    """Watch every executor's streams and every collision check (the methods still run)."""
    watch = StreamWatch()
    first_contact, send, stream = (
        CollisionModel.first_contact, Executor.send, Executor.stream
    )  # fmt: skip

    def spied_contact(self: CollisionModel, q_path: Any, **kwargs: Any) -> Any:
        watch.checked.add(np.atleast_2d(np.asarray(q_path, dtype=float))[1:].tobytes())
        return first_contact(self, q_path, **kwargs)

    def spied_send(self: Executor, q: Any, *args: Any, **kwargs: Any) -> Any:
        if watch._sending:
            watch._sending[-1].append(np.asarray(q, dtype=float))
        return send(self, q, *args, **kwargs)

    def spied_stream(self: Executor, route: Any, *args: Any, **kwargs: Any) -> Any:
        watch._sending.append([])
        try:
            return stream(self, route, *args, **kwargs)
        finally:
            watch.streamed.append(np.array(watch._sending.pop()))  # after its first pose

    monkeypatch.setattr(CollisionModel, "first_contact", spied_contact)
    monkeypatch.setattr(Executor, "send", spied_send)
    monkeypatch.setattr(Executor, "stream", spied_stream)
    return watch
