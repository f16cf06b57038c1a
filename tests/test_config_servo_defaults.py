"""A servo whose calibration line was left out of the config: the pulse-range error says so.

``zero_us``, ``direction`` and ``us_per_unit`` each have a default (a guess, not a
measurement). A maker who forgot ``zero_us`` on the elbow read "limits.min: -150 needs a
-165 µs pulse, outside the servo's [500, 2500] µs" and looked for a wrong limit.
"""

from __future__ import annotations

import pytest
import yaml

from mearm.config import load_config
from mearm.errors import ConfigError


def _elbow_without(tmp_path, *fields: str, **servo: object):
    """The simulated rig's arm, its elbow servo without ``fields`` and with ``servo``."""
    arm = load_config("sim").arm.model_dump(mode="json", exclude_none=True)
    elbow = next(j for j in arm["joints"] if j["name"] == "elbow")
    for field in fields:
        del elbow["servo"][field]
    elbow["servo"].update(servo)
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump({"arm": arm}), encoding="utf-8")
    return path


def test_a_forgotten_zero_us_is_named_in_the_pulse_error(tmp_path):
    with pytest.raises(ConfigError) as info:
        load_config(_elbow_without(tmp_path, "zero_us"))
    said = str(info.value)
    assert "arm.joints.elbow.limits" in said and "µs pulse, outside the servo's" in said
    assert "(zero_us 1500: not given, the defaults)" in said, said


def test_a_calibration_written_in_full_names_no_default(tmp_path):
    """The same error from a limit that is really out of range says nothing of defaults."""
    with pytest.raises(ConfigError) as info:  # -160 deg: 800 µs
        load_config(_elbow_without(tmp_path, min_us=900))
    assert "µs pulse, outside the servo's" in str(info.value)
    assert "not given" not in str(info.value)
