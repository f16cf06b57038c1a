"""``init-config --of MINE``: the twin's name and its ``extends`` as the loader reads them.

A config's ``extends`` names a file beside it, else a packaged config: a twin written
beside the maker's config under the name of the packaged config it extends (``sim.yaml``)
was read instead of it, so the two extended each other and neither loaded, after an
exit 0 that said "Next: mearm sort".
"""

from __future__ import annotations

from pathlib import Path

from badinput import run_in_process

from mearm.config import load_config
from mearm.maker import init_config


def test_a_twin_that_would_shadow_what_the_config_extends_is_refused(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert init_config.main(["--arm", "paper", "--rig", "uno", "my_arm.yaml"]) == 0
    mine = (tmp_path / "my_arm.yaml").read_text(encoding="utf-8")
    assert "\nextends: sim.yaml\n" in mine  # the packaged sim.yaml, by name
    r = run_in_process(["init-config", "--of", "my_arm.yaml", "--rig", "sim", "sim.yaml"])
    assert r.code == 2 and r.stdout == "", r
    line = r.stderr.strip()
    assert "\n" not in line and "my_arm.yaml extends sim.yaml" in line, line
    assert "another name or in another folder" in line
    assert not (tmp_path / "sim.yaml").exists()  # nothing written
    assert (tmp_path / "my_arm.yaml").read_text(encoding="utf-8") == mine
    load_config("my_arm.yaml")  # the maker's config still loads
    # with --force over a file of that name (the maker's own sim.yaml): kept as it is
    (tmp_path / "sim.yaml").write_text("extends: sim_4colours\n", encoding="utf-8")
    argv = ["init-config", "--of", "my_arm.yaml", "--rig", "sim", "--force", "sim.yaml"]
    r = run_in_process(argv)
    assert r.code == 2 and "my_arm.yaml extends sim.yaml" in r.stderr, r
    assert (tmp_path / "sim.yaml").read_text(encoding="utf-8") == "extends: sim_4colours\n"
    assert not (tmp_path / "sim.yaml.bak").exists()


def test_a_twin_of_that_name_elsewhere_is_written(tmp_path, monkeypatch, capsys):
    """Another name, or the same name in another folder, shadows nothing."""
    monkeypatch.chdir(tmp_path)
    assert init_config.main(["--arm", "paper", "--rig", "sim", "my_arm.yaml"]) == 0
    for out in ("twin.yaml", "sub/sim.yaml"):
        assert init_config.main(["--of", "my_arm.yaml", "--rig", "sim", out]) == 0
        assert load_config(out).arm.name == load_config("my_arm.yaml").arm.name
    capsys.readouterr()
    assert Path("my_arm.yaml").is_file()


def test_a_twin_of_a_packaged_config_by_name_extends_it_by_name(tmp_path, monkeypatch, capsys):
    """``--of sim`` (no such file here) names the packaged config: the twin in another
    folder extends ``sim``, not ``../sim``, which named no file ("no packaged config has
    that name (packaged: lab, sim, …)")."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub2").mkdir()
    for of, out in (("sim", "sub2/x.yaml"), ("sim.yaml", "new/y.yaml")):
        assert init_config.main(["--of", of, "--rig", "sim", out]) == 0, capsys.readouterr()
        assert f"(it extends {of})" in capsys.readouterr().out
        assert f"\nextends: {of}\n" in Path(out).read_text(encoding="utf-8")
        assert load_config(out).arm.name == load_config("sim").arm.name
    # a file of the packaged config's name beside the twin would be read instead
    (tmp_path / "sub2" / "sim.yaml").write_text("extends: sim_4colours\n", encoding="utf-8")
    r = run_in_process(["init-config", "--of", "sim.yaml", "--rig", "sim", "sub2/z.yaml"])
    assert r.code == 2 and "the twin extends the packaged sim.yaml" in r.stderr, r
    assert not (tmp_path / "sub2" / "z.yaml").exists()
