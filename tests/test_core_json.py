"""CAL_DIR/core.json written by an earlier fringe still loads.

Issue 10 gave fringe_trim's CoreConfig fields their block's prefix (speed_log2 -> trim_speed_log2, map_psi_w,
map_phi_w, g_shift likewise; config.RENAMED_FIELDS). A calibration folder of the previous version holds the old
names (in core.json and rom/core.json, its manifests agreeing): `core_config` reads them under the new names, every
command takes the folder as before, and what fringe writes carries the new names only.
"""

import json
import os

import pytest
from cli_runs import simulate_pair

from fringe.cli.cli import main
from fringe.fixed.config import RENAMED_FIELDS, CoreConfig, current_field_names
from fringe.io.outputs import MANIFEST, write_manifest

#: the HDL parameters the previous version wrote into core.json under other names (TRIM = 1 / DRIFT = 1 only)
OLD_HDL_NAMES = {"TRIM_SPEED_LOG2": "SPEED_LOG2", "TRIM_MAP_PSI_W": "MAP_PSI_W", "TRIM_MAP_PHI_W": "MAP_PHI_W",
                 "TRIM_G_SHIFT": "G_SHIFT", "TRIM_SECT_RECIP": "SECT_RECIP", "TRIM_SECT_SHIFT": "SECT_SHIFT"}
#: non-default values for the renamed fields, so that a field read under the wrong name shows
OLD_VALUES = {"speed_log2": 3, "map_psi_w": 4, "map_phi_w": 6, "g_shift": 20}


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return simulate_pair(tmp_path_factory.mktemp("core_json"), 20000, 3000, calibrate=True)


def _rewrite(folder, edit_config):
    """Every core.json of a calibration folder with its config edited, the manifests (rom/ first) written anew,
    as the fringe that wrote the folder would have."""
    for sub in ("rom", "."):
        path = os.path.join(folder, sub, "core.json")
        doc = json.loads(open(path, encoding="utf-8").read())
        doc["config"] = edit_config(doc["config"])
        if doc["config"].get("trim"):
            doc["hdl_parameters"] = {OLD_HDL_NAMES.get(k, k): v for k, v in doc["hdl_parameters"].items()}
        with open(path, "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=2, sort_keys=True)
            f.write("\n")
        man = json.loads(open(os.path.join(folder, sub, MANIFEST), encoding="utf-8").read())
        write_manifest(os.path.join(folder, sub), man["kind"], man["command"])


def _folder(work, name, config) -> str:
    """A copy of the calibration with `config` (a function of the saved config) in its core.json files."""
    import shutil

    dst = work / name
    if not dst.exists():
        shutil.copytree(work / "cal", dst)
        _rewrite(str(dst), config)
    return str(dst)


def _old(config: dict, **values) -> dict:
    """The previous version's names (and `values` under them), the new ones gone."""
    new_to_old = {new: old for old, new in RENAMED_FIELDS.items()}
    return {new_to_old.get(k, k): v for k, v in config.items()} | values


def _new(config: dict, **values) -> dict:
    return config | {RENAMED_FIELDS[k]: v for k, v in values.items()}


def test_current_field_names():
    saved = {"adc_w": 12, "speed_log2": 3, "map_psi_w": 4, "map_phi_w": 6, "g_shift": 20, "trim": 1, "trim_w": 16}
    assert current_field_names(saved) == {"adc_w": 12, "trim_speed_log2": 3, "trim_map_psi_w": 4,
                                          "trim_map_phi_w": 6, "trim_g_shift": 20, "trim": 1, "trim_w": 16}
    assert "speed_log2" in saved                                   # the caller's dict is left alone
    current = CoreConfig().to_dict()
    assert current_field_names(current) == current                 # today's names pass unchanged
    assert set(RENAMED_FIELDS.values()) <= set(current) and not set(RENAMED_FIELDS) & set(current)
    with pytest.raises(ValueError, match="'g_shift' and 'trim_g_shift' name one field"):
        current_field_names({"g_shift": 20, "trim_g_shift": 20})
    with pytest.raises(ValueError, match="not an object"):
        current_field_names([1, 2])


@pytest.mark.parametrize("trim", [0, 1])
def test_an_old_core_json_loads_with_its_values(work, trim):
    """The previous version's core.json (its names, its values) gives the configuration the new names give."""
    from fringe.hardware.corefiles import core_config
    from fringe.io.calstore import load_calibration

    old = _folder(work, f"cal_old_{trim}", lambda c: _old(c, trim=trim, **OLD_VALUES))
    new = _folder(work, f"cal_new_{trim}", lambda c: _new(c, **OLD_VALUES) | {"trim": trim})
    saved = json.loads(open(os.path.join(old, "core.json"), encoding="utf-8").read())["config"]
    assert not set(RENAMED_FIELDS.values()) & set(saved) and set(RENAMED_FIELDS) <= set(saved)
    cal = load_calibration(old)
    cfg = core_config(cal, old)
    assert cfg == core_config(cal, new)
    assert (cfg.trim, cfg.trim_speed_log2, cfg.trim_map_psi_w, cfg.trim_map_phi_w, cfg.trim_g_shift) == (trim, 3, 4, 6,
                                                                                                         20)
    if trim:
        assert {"TRIM_SPEED_LOG2": 3, "TRIM_MAP_PSI_W": 4, "TRIM_MAP_PHI_W": 6, "TRIM_G_SHIFT": 20}.items() <= \
            cfg.hdl_parameters().items()


def test_commands_take_an_old_folder_and_write_the_new_names(work, capsys):
    old = _folder(work, "cal_old_1", lambda c: _old(c, trim=1, **OLD_VALUES))
    new = _folder(work, "cal_new_1", lambda c: _new(c, **OLD_VALUES) | {"trim": 1})
    rows = {}
    for name, cal in (("old", old), ("new", new)):
        out = work / f"{name}.csv"
        assert main(["correct", str(work / "b.csv"), "--cal", cal, "--out", str(out)]) == 0
        rows[name] = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")]
        assert main(["rom", cal, "--out", str(work / f"rom_{name}")]) == 0
    assert len(rows["old"]) == 3001 and rows["old"] == rows["new"]
    for name in ("old", "new"):
        doc = json.loads((work / f"rom_{name}" / "core.json").read_text())
        assert not set(RENAMED_FIELDS) & set(doc["config"]), doc["config"]
        assert {doc["config"][k] for k in ("trim_speed_log2", "trim_map_psi_w", "trim_map_phi_w",
                                           "trim_g_shift")} == {3, 4, 6, 20}
        assert not set(OLD_HDL_NAMES.values()) & set(doc["hdl_parameters"])
        assert doc["hdl_parameters"]["TRIM_G_SHIFT"] == 20
    for f in sorted(os.listdir(work / "rom_old")):
        if f.endswith(".mem"):
            assert [ln for ln in (work / "rom_old" / f).read_text().splitlines() if not ln.startswith("//")] == \
                [ln for ln in (work / "rom_new" / f).read_text().splitlines() if not ln.startswith("//")], f


def test_a_field_under_both_names_is_refused(work, capsys):
    both = _folder(work, "cal_both", lambda c: c | {"g_shift": 20})
    status = main(["rom", both, "--out", str(work / "rom_both")])
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err and "core.json" in err and "'g_shift' and 'trim_g_shift'" in err, err
    assert not (work / "rom_both").exists()


def test_a_core_json_without_drift_hold_loads(work):
    """A core.json written before DRIFT_HOLD existed loads with the default, DRIFT_HOLD = 1 (the tracker's
    words follow the new timing; its constants keep their meaning)."""
    from fringe.hardware.corefiles import core_config
    from fringe.io.calstore import load_calibration

    folder = _folder(work, "cal_no_hold", lambda c: {k: v for k, v in c.items() if k != "drift_hold"})
    saved = json.loads(open(os.path.join(folder, "core.json"), encoding="utf-8").read())["config"]
    assert "drift_hold" not in saved and "drift_mu_log2" in saved
    cfg = core_config(load_calibration(folder), folder)
    assert cfg.drift_hold == 1 == CoreConfig().drift_hold
