"""Reading format 1: one format-1 record's mapping → the same record in format 2.

Format 1 knew one arm and three colours. Its joint values were lists by position —
``start_joints_deg``, ``end_joints_deg`` and ``last_joints_deg``, (θ1, θ2, θ3, θ4) [deg] —
and its header's ``config`` had the ``robot:`` layout. Format 2 keys joint values by
joint name and stores the current config layout. The conversion, per record type:

- ``header``: ``config`` → :func:`~mearm.config.migrate.migrate_v1_config` (joints named
  ``joint1``..``joint4``, colours as classes); ``format`` stays 1, saying what the file
  holds.
- ``route``: ``start_joints_deg`` → ``start_joints``, ``end_joints_deg`` → ``end_joints``,
  each ``[a, b, c, d]`` → ``{joint1: a, joint2: b, joint3: c, joint4: d}``.
- ``fault``: ``last_joints_deg`` → ``last_joints`` the same way (``null`` stays ``null``).
- ``skip`` and ``summary``: unchanged (a colour's name is a class's name).

The names are the ones the migrated header's arm has, so a format-1 trial reads as a
consistent format-2 trial.
"""

from __future__ import annotations

from typing import Any

from mearm.config.migrate import V1_JOINT_NAMES, migrate_v1_config
from mearm.errors import ConfigError

#: Format-1 joint lists → their format-2 names, per record type.
V1_JOINT_FIELDS: dict[str, tuple[tuple[str, str], ...]] = {
    "route": (("start_joints_deg", "start_joints"), ("end_joints_deg", "end_joints")),
    "fault": (("last_joints_deg", "last_joints"),),
}


def _named(values: Any, field: str) -> dict[str, Any]:
    if not isinstance(values, list) or len(values) != len(V1_JOINT_NAMES):
        raise ValueError(
            f"field '{field}' must be a list of {len(V1_JOINT_NAMES)} joint angles "
            f"(θ1..θ4) [deg], got {values!r}"
        )
    return dict(zip(V1_JOINT_NAMES, values, strict=True))


def upgrade_v1_record(obj: dict[str, Any]) -> dict[str, Any]:
    """A format-1 record's mapping in the format-2 layout (rules in the module doc).

    Args:
        obj: One parsed line; its ``type`` is a known record type.

    Returns:
        A new mapping; fields this conversion does not touch are kept as they are, for
        the record's model to validate.

    Raises:
        ValueError: A joint list is missing or not four values, or the header's config
            cannot be migrated; the message names the format-1 field.
    """
    kind = obj.get("type")
    out = dict(obj)
    if kind == "header" and isinstance(out.get("config"), dict):
        try:
            out["config"] = migrate_v1_config(out["config"], source="format-1 header")
        except ConfigError as exc:
            raise ValueError(f"field 'config' cannot be migrated: {exc}") from None
    for old, new in V1_JOINT_FIELDS.get(str(kind), ()):
        if old not in out:
            raise ValueError(f"field '{old}' is missing")
        values = out.pop(old)
        out[new] = None if values is None and kind == "fault" else _named(values, old)
    return out
