"""`Mechanism.check()` holds what `kanedyn check FILE` prints, read back from the CLI's text."""

import re

import pytest

import kanedyn
from conftest import EXAMPLES

MECHANISMS = ["cpva", "cpva4", "triple_pendulum", "joint_kinds", "shaft_cpva"]

BODY = re.compile(r"^  (\S+)\s+mass\s+(\S+) kg   com \((\S+), (\S+)\) m   inertia (\S+) kg·m²$")
JOINT = re.compile(
    r"^  (?:q\[(\d+)\]|    ) (\S+)\s+(Revolute|Fixed|Prismatic \{ axis: \((\S+), (\S+)\) \}) (\S+) -> (\S+) "
    r"at \((\S+), (\S+)\) m(.*)$"
)
DAMPER = re.compile(r"   damper (\S+) (N·m|N)·s/(rad|m)")
SPRING = re.compile(r"   spring (\S+) (N·m|N)/(rad|m) \(free at (\S+) (rad|m)\)")
ABSORBER = re.compile(r"^\| `(\S+)` \| ([^|]+?) \| (\S+) \| (\S+) \| (\S+) \| (\S+) \| ([^|]+?) \| ([^|]+?) \|$")
LOADS = re.compile(
    r"^loads: gravity \((\S+), (\S+)\) m/s², (\d+) joint torque\(s\), (\d+) damper\(s\) to ground, "
    r"(\d+) point force\(s\)$"
)


def parse_check(text):
    """The CLI's `check` output as a dict shaped like `Mechanism.check()`'s."""
    lines = text.splitlines()
    head = re.match(r"^mechanism `(.+)` \((.+)\): OK$", lines[0])
    out = {"name": head[1], "file": head[2], "bodies": [], "joints": []}
    for line in lines[1:]:
        if m := re.match(r"^degrees of freedom: (\d+)$", line):
            out["degrees_of_freedom"] = int(m[1])
        elif m := re.match(r"^generalized speeds: (\S+)$", line):
            out["speeds"] = m[1]
        elif m := BODY.match(line):
            out["bodies"].append(
                {"name": m[1], "mass": m[2], "com": (m[3], m[4]), "inertia": float(m[5])}
            )
        elif m := JOINT.match(line):
            kind = m[3].split()[0]
            joint = {
                "coordinate": None if m[1] is None else int(m[1]),
                "name": m[2],
                "kind": kind,
                "axis": (float(m[4]), float(m[5])) if kind == "Prismatic" else None,
                "parent": m[6],
                "child": m[7],
                "at": (float(m[8]), float(m[9])),
                "damper": 0.0,
                "spring": None,
                "units": {},
            }
            if d := DAMPER.search(m[10]):
                joint["damper"] = float(d[1])
                joint["units"]["unit"] = d[3]
                joint["units"]["damper_unit"] = f"{d[2]}·s/{d[3]}"
            if s := SPRING.search(m[10]):
                joint["spring"] = {"stiffness": float(s[1]), "free_angle": float(s[4])}
                joint["units"]["unit"] = s[5]
                joint["units"]["spring_unit"] = f"{s[2]}/{s[3]}"
            out["joints"].append(joint)
        elif m := LOADS.match(line):
            out["loads"] = {
                "gravity": (float(m[1]), float(m[2])),
                "joint_torques": int(m[3]),
                "ground_dampers": int(m[4]),
                "point_forces": int(m[5]),
            }
        elif m := re.match(r"^total mass: (\S+) kg$", line):
            out["total_mass"] = float(m[1])
        elif m := ABSORBER.match(line):
            out.setdefault("absorbers", []).append(
                {"joint": m[1], "kind": m[2], "mass": m[3], "inertia": float(m[4]), "tuning_order": m[5]}
            )
        elif line == "## Absorbers" or line == "" or line.startswith("At held spin") or line.startswith("|"):
            pass  # the absorbers' heading, note and table frame
        elif not re.match(r"^(bodies: \d+|joints \(tree order\): \d+)$", line):
            raise AssertionError(f"unparsed line of `kanedyn check`: {line!r}")
    return out


@pytest.mark.parametrize("name", MECHANISMS)
def test_check_holds_what_the_cli_prints(cli, name):
    path = f"examples/{name}.ron"  # relative, as typed: both tools echo the path as given
    ok, out, err = cli("check", path)
    assert ok, err
    want = parse_check(out)
    got = kanedyn.Mechanism.from_file(EXAMPLES.parent / path).check()
    assert got["name"] == want["name"]
    assert got["file"] == str(EXAMPLES.parent / path)
    assert got["degrees_of_freedom"] == want["degrees_of_freedom"]
    assert got["speeds"] == want["speeds"]
    assert got["total_mass"] == want["total_mass"]
    assert got["loads"] == want["loads"]
    assert [b["name"] for b in got["bodies"]] == [b["name"] for b in want["bodies"]]
    for g, w in zip(got["bodies"], want["bodies"]):
        # The CLI rounds: mass and com to 6 decimals, inertia to 7 significant digits.
        assert f"{g['mass']:.6f}" == w["mass"], g
        assert tuple(f"{c:.6f}" for c in g["com"]) == w["com"], g
        assert float(f"{g['inertia']:.6e}") == w["inertia"], g
    assert len(got["joints"]) == len(want["joints"])
    for g, w in zip(got["joints"], want["joints"]):
        for key in ("name", "kind", "parent", "child", "at", "coordinate", "damper", "spring"):
            assert g[key] == w[key], (key, g, w)
        if g["kind"] == "Prismatic":
            # The CLI prints the axis normalised at load, as the dict holds it.
            assert g["axis"] == w["axis"]
        else:
            assert g["axis"] is None
        # Where the CLI names a unit (with a damper or a spring), the dict has the same.
        for key, unit in w["units"].items():
            assert g[key] == unit, (key, g)
        for key in ("unit", "damper_unit", "spring_unit"):
            assert (g[key] is None) == (g["coordinate"] is None)
    # Each example shows the units of a revolute joint, and joint_kinds those of a slide too.
    shown = {u for j in want["joints"] for u in j["units"].values()}
    assert "N·m·s/rad" in shown or "N·m/rad" in shown, shown
    if name == "joint_kinds":
        assert {"N·s/m", "N/m", "m"} <= shown
    assert [j["coordinate"] for j in got["joints"] if j["coordinate"] is not None] == list(
        range(got["degrees_of_freedom"])
    )
    # The absorbers (the CLI's table: mass and n_t to 6 decimals, I to 7 significant digits).
    assert [a["joint"] for a in got["absorbers"]] == [a["joint"] for a in want.get("absorbers", [])]
    for g, w in zip(got["absorbers"], want.get("absorbers", [])):
        assert g["kind"] == w["kind"] and f"{g['mass']:.6f}" == w["mass"], (g, w)
        assert float(f"{g['inertia']:.6e}") == w["inertia"] and f"{g['tuning_order']:.6f}" == w["tuning_order"], (g, w)
    if name == "cpva":
        assert got["absorbers"][0]["kind"] == "Revolute pendulum" and abs(got["absorbers"][0]["tuning_order"] - 3.11) < 1e-9
    mech = kanedyn.Mechanism.from_file(EXAMPLES.parent / path)
    assert mech.ndof == want["degrees_of_freedom"]
    assert mech.coordinate_names == [j["name"] for j in want["joints"] if j["coordinate"] is not None]


def test_check_of_text_names_the_name_given(monkeypatch):
    text = (EXAMPLES / "triple_pendulum.ron").read_text()
    got = kanedyn.Mechanism.from_str(text, name=str(EXAMPLES / "triple_pendulum.ron")).check()
    assert got["file"] == str(EXAMPLES / "triple_pendulum.ron")
    assert got["degrees_of_freedom"] == 3
    # Without a name, parts are looked up from the current folder.
    monkeypatch.chdir(EXAMPLES)
    assert kanedyn.Mechanism.from_str(text).file == "<string>"
