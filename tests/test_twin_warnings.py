"""MuJoCo's warnings reach the log, not a MUJOCO_LOG.TXT file in the working folder."""

from __future__ import annotations

import logging

import mujoco

import mearm.sim.twin.twin_bus  # noqa: F401  (installs the handler)


def test_a_mujoco_warning_is_logged_not_written_to_the_cwd(tmp_path, monkeypatch, caplog):
    monkeypatch.chdir(tmp_path)
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>'
    )
    d = mujoco.MjData(m)
    d.qpos[0] = float("nan")
    with caplog.at_level(logging.WARNING, logger="mearm.sim.twin.twin_bus"):
        mujoco.mj_step(m, d)
    assert any("MuJoCo: Nan, Inf or huge value in QPOS" in r.message for r in caplog.records)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
