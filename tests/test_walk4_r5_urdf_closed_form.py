"""``mearm urdf`` refuses an ``arm.closed_form`` its arm cannot use (docs/your-arm.md).

A maker starts a new arm from the MeArm's ``arm:`` block and keeps ``closed_form:
planar_wrist``, or misspells it: the sort stops on it at its start, so the URDF tool, which
validates the description the way a run would, refuses it too (exit 2, one line naming the
config and the field) and writes nothing.
"""

import pytest
from badinput import run_in_process

#: A four-actuated-joint arm of one's own (no passive wrist): not the planar_wrist family.
OWN_ARM = """\
arm:
  name: my_arm
  joints:
    - name: base
      dh: {alpha_deg: 90.0, d_cm: 7.0}
      limits: {min: 20.0, max: 160.0}
      home: 90.0
      servo: {channel: 0, zero_us: 500.0, us_per_unit: 11.1, min_us: 500, max_us: 2500}
    - name: shoulder
      dh: {a_cm: 10.0}
      limits: {min: 20.0, max: 160.0}
      home: 90.0
      servo: {channel: 1, zero_us: 500.0, us_per_unit: 11.1, min_us: 500, max_us: 2500}
    - name: elbow
      dh: {a_cm: 9.0}
      limits: {min: -150.0, max: -10.0}
      home: -90.0
      servo: {channel: 2, zero_us: 2500.0, us_per_unit: 11.1, min_us: 500, max_us: 2500}
    - name: wrist
      dh: {a_cm: 5.0}
      limits: {min: -90.0, max: 90.0}
      home: 0.0
      servo: {channel: 3, zero_us: 1500.0, us_per_unit: 11.1, min_us: 500, max_us: 2500}
  tool:
    tcp_cm: [0.0, 0.0, 0.0]
    approach_axis: [1.0, 0.0, 0.0]
    gripper:
      name: gripper
      servo: {channel: 4, zero_us: 1730.0, direction: -1, us_per_unit: 137.7, min_us: 544}
      open_cm: 3.0
      closed_cm: 0.0
      jaw_length_cm: 3.0
  closed_form: {closed_form}
"""


@pytest.mark.parametrize(
    ("closed_form", "said"),
    [
        (
            "planar_wrist",
            "'planar_wrist' needs three actuated joints and a passive fourth; this arm has "
            "another structure (set closed_form to null)",
        ),
        (
            "planar_wirst",
            "unknown closed form 'planar_wirst' (registered: planar_wrist); or set it to null",
        ),
    ],
)
def test_an_arm_its_closed_form_does_not_fit_is_refused(tmp_path, monkeypatch, closed_form, said):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_arm.yaml").write_text(OWN_ARM.replace("{closed_form}", closed_form))
    out = tmp_path / "my_arm.urdf"
    r = run_in_process(["urdf", "--config", "my_arm.yaml", "--output", out])
    assert r.code == 2, (r.stdout, r.stderr)
    assert r.stderr.splitlines() == [f"mearm urdf: error: my_arm.yaml: arm.closed_form: {said}"]
    assert r.stdout == "" and not out.exists()


def test_the_same_arm_without_a_closed_form_is_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my_arm.yaml").write_text(OWN_ARM.replace("{closed_form}", "null"))
    out = tmp_path / "my_arm.urdf"
    r = run_in_process(["urdf", "--config", "my_arm.yaml", "--output", out])
    assert (r.code, r.stderr) == (0, "")
    assert r.stdout == f"wrote {out}\n" and '<robot name="my_arm"' in out.read_text()
