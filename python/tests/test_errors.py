"""Every bad mechanism file of the Rust tests raises a kanedyn exception with the CLI's message.

The cases are those of tests/it/ron_errors.rs, tests/it/input_hardening.rs, tests/it/joint_kinds.rs
(bad joint kinds) and tests/it/cli.rs that concern a mechanism file. Each is written to a file and
given to `kanedyn check` and `kanedyn eom`; the Python exception's text must equal what the CLI
prints after `error: ` (file, line:column, field and reason), and the words the Rust test looks
for must be in it, so that a case still fails for the reason it was written for.
"""

import os
import sys
from pathlib import Path

import pytest

import kanedyn
from conftest import EXAMPLES, ROOT

# The valid two-body file of tests/it/ron_errors.rs; most cases break one thing in it.
GOOD = """Mechanism(
    name: "m",
    bodies: [
        Body(name: "rotor", mass: 10.0, inertia: 1.0),
        Body(name: "arm", mass: 1.0, com: (0.1, 0.0), inertia: 0.01),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "pivot", parent: "rotor", child: "arm", at: (0.2, 0.0)),
    ],
)
"""

SECRET = "root:x:0:0:hunter2:/root:/bin/bash\n"


def with_loads(loads):
    return GOOD.replace("    ],\n)", f"    ],\n    loads: [{loads}],\n)")


def with_part(part):
    """A one-body mechanism whose body is the catalog part `part` (tests/it/input_hardening.rs)."""
    return (
        'Mechanism(\n    name: "m",\n    bodies: [Body(name: "rotor", part: "%s")],\n'
        '    joints: [Joint(name: "spin", parent: "ground", child: "rotor")],\n)\n' % part
    )


def one_body(body):
    """A one-body mechanism whose body is `body` (`body_error` of tests/it/input_hardening.rs)."""
    return (
        'Mechanism(\n  name: "m",\n  bodies: [\n    %s,\n  ],\n'
        '  joints: [Joint(name: "j", parent: "ground", child: "b")],\n)' % body
    )


def with_second_joint(joint, loads=""):
    """The two-body file of the bad joint kinds (tests/it/joint_kinds.rs)."""
    bodies = (
        'bodies: [\n        Body(name: "rotor", mass: 1.0, inertia: 0.1),\n'
        '        Body(name: "arm", mass: 0.5, com: (0.1, 0.0), inertia: 0.01),\n    ],'
    )
    return (
        f'Mechanism(\n    name: "m",\n    {bodies}\n    joints: [\n'
        f'        Joint(name: "spin", parent: "ground", child: "rotor"),\n        {joint},\n    ],\n'
        f"    loads: [{loads}],\n)\n"
    )


def chain(n):
    """A chain of n bodies (the 10,001-body case of tests/it/input_hardening.rs)."""
    bodies = "".join(f'Body(name: "b{i}", mass: 1.0, com: (0.5, 0.0), inertia: 0.1),\n' for i in range(n))
    joints = "".join(
        f'Joint(name: "j{i}", parent: "{"ground" if i == 0 else f"b{i - 1}"}", child: "b{i}", at: (1.0, 0.0)),\n'
        for i in range(n)
    )
    return f'Mechanism(name: "chain", bodies: [\n{bodies}], joints: [\n{joints}])\n'


def deep_part():
    shape = "Disc(radius: 1.0)"
    for _ in range(5000):
        shape = f"Compound(parts: [Placed(shape: {shape})])"
    return f'Body(name: "b", areal_density: 1.0, shape: {shape})'


class Case:
    """One bad input: files to write under a fresh folder, the file to load, what to expect."""

    def __init__(
        self,
        id,
        files,
        words,
        kind=kanedyn.InputError,
        target="m.ron",
        flags=(),
        kwargs=None,
        links=(),
        fifos=(),
        source="",
    ):
        self.id, self.files, self.words, self.kind, self.target = id, files, words, kind, target
        self.flags, self.kwargs, self.links, self.fifos, self.source = flags, kwargs or {}, links, fifos, source

    def write(self, root: Path) -> Path:
        """Writes the files; returns the path to load (absolute unless the case names one)."""
        for rel, content in self.files.items():
            p = root / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(content, bytes):
                p.write_bytes(content)
            else:
                p.write_text(content, encoding="utf-8")
        for link, to in self.links:
            os.symlink(root / to, root / link)
        for fifo in self.fifos:
            os.mkfifo(root / fifo)
        return Path(self.target) if os.path.isabs(self.target) else root / self.target


def case(source, *args, **kwargs):
    return Case(*args, source=source, **kwargs)


CASES = [
    # tests/it/ron_errors.rs
    case("ron_errors", "syntax", {"m.ron": GOOD.replace("inertia: 1.0)", "inertia: 1.0")}, ["m.ron:5:"]),
    case("ron_errors", "unknown-field", {"m.ron": GOOD.replace("mass: 10.0", "mas: 10.0")}, ["m.ron:4:", "bodies[0]", "mas"]),
    case(
        "ron_errors",
        "unknown-body",
        {"m.ron": GOOD.replace('parent: "rotor"', 'parent: "rotr"')},
        ["m.ron:9:38", "joints[1].parent", "unknown parent body `rotr`", "rotor, arm"],
    ),
    case(
        "ron_errors",
        "dup-body",
        {"m.ron": GOOD.replace('name: "arm"', 'name: "rotor"')},
        ["m.ron:5:", "bodies[1].name", "duplicate body name `rotor`"],
    ),
    case(
        "ron_errors",
        "dup-joint",
        {"m.ron": GOOD.replace('name: "pivot"', 'name: "spin"')},
        ["joints[1].name", "duplicate joint name `spin`"],
    ),
    case(
        "ron_errors",
        "two-parents",
        {
            "m.ron": GOOD.replace(
                '        Joint(name: "pivot"',
                '        Joint(name: "extra", parent: "ground", child: "arm"),\n        Joint(name: "pivot"',
            )
        },
        ["joints[2].child", "body `arm` has two parents", "extra", "pivot"],
    ),
    case(
        "ron_errors",
        "no-parent",
        {"m.ron": GOOD.replace('        Joint(name: "pivot", parent: "rotor", child: "arm", at: (0.2, 0.0)),', "")},
        ["m.ron:5:", "bodies[1]", "body `arm` is not attached"],
    ),
    case(
        "ron_errors",
        "cycle",
        {"m.ron": GOOD.replace('Joint(name: "spin", parent: "ground", child: "rotor")', 'Joint(name: "spin", parent: "arm", child: "rotor")')},
        ["cycle", "rotor, arm"],
    ),
    case(
        "ron_errors",
        "self-loop",
        {"m.ron": GOOD.replace('parent: "rotor", child: "arm"', 'parent: "arm", child: "arm"')},
        ["joints[1].parent", "to itself"],
    ),
    case(
        "ron_errors",
        "massless",
        {"m.ron": GOOD.replace("mass: 1.0, com: (0.1, 0.0), inertia: 0.01", "com: (0.1, 0.0)")},
        ["m.ron:5:9", "bodies[1]", "no mass and no inertia"],
    ),
    case(
        "ron_errors",
        "negative-mass",
        {"m.ron": GOOD.replace("mass: 10.0", "mass: -10.0")},
        ["m.ron:4:35", "bodies[0].mass", "negative mass"],
    ),
    case(
        "ron_errors",
        "negative-inertia",
        {"m.ron": GOOD.replace("inertia: 0.01", "inertia: -0.01")},
        ["bodies[1].inertia", "negative moment of inertia"],
    ),
    case("ron_errors", "nan", {"m.ron": GOOD.replace("mass: 10.0", "mass: NaN")}, ["bodies[0].mass", "finite"]),
    case("ron_errors", "inf", {"m.ron": GOOD.replace("at: (0.2, 0.0)", "at: (inf, 0.0)")}, ["joints[1].at", "finite"]),
    case(
        "ron_errors",
        "neg-damper",
        {"m.ron": GOOD.replace("at: (0.2, 0.0)", "at: (0.2, 0.0), damper: -1.0")},
        ["joints[1].damper", "non-negative"],
    ),
    case(
        "ron_errors",
        "singular",
        {"m.ron": GOOD.replace("mass: 1.0, com: (0.1, 0.0), inertia: 0.01", "mass: 1.0")},
        ["m.ron:9:", "joints[1]", "not positive definite", "pivot"],
    ),
    case(
        "ron_errors",
        "load-body",
        {"m.ron": with_loads('GroundDamper(body: "rotorr", c: 1.0)')},
        ["loads[0].body", "unknown body `rotorr`"],
    ),
    case(
        "ron_errors",
        "load-joint",
        {"m.ron": with_loads('JointTorque(joint: "spinn", excitation: (mean: 1.0))')},
        ["loads[0].joint", "unknown joint `spinn`"],
    ),
    case(
        "ron_errors",
        "load-rpm",
        {"m.ron": with_loads('JointTorque(joint: "spin", excitation: (harmonics: [(multiple: 1.0, amplitude: 2.0)]))')},
        ["loads[0].excitation.rpm", "reference speed"],
    ),
    case(
        "ron_errors",
        "part-missing",
        {"m.ron": GOOD.replace('Body(name: "rotor", mass: 10.0, inertia: 1.0)', 'Body(name: "rotor", part: "nope.ron")')},
        ["m.ron:4:", "bodies[0].part", "nope.ron"],
    ),
    case(
        "ron_errors",
        "part-bad",
        {
            "p.ron": "Body(mass: -3.0)",
            "m.ron": GOOD.replace('Body(name: "rotor", mass: 10.0, inertia: 1.0)', 'Body(name: "rotor", part: "p.ron")'),
        },
        ["p.ron:1:", "negative mass"],
    ),
    case("ron_errors", "missing-file", {}, ["/nonexistent/kanedyn.ron", "cannot read"], kind=kanedyn.ReadError, target="/nonexistent/kanedyn.ron"),
    # tests/it/input_hardening.rs
    *[
        case(
            "input_hardening",
            f"part-outside-{i}",
            {"outside.ron": "Body(mass: 1.0, inertia: 1.0)", "mech/m.ron": with_part(part)},
            words,
            target="mech/m.ron",
        )
        for i, (part, words) in enumerate(
            [
                ("../outside.ron", ["m.ron:3:", "bodies[0].part", "--allow-read DIR", "--allow-any-path", "outside"]),
                ("../missing.ron", ["m.ron:3:", "bodies[0].part", "--allow-read DIR", "outside"]),
                ("sub/../../outside.ron", ["--allow-read DIR"]),
                ("/etc/passwd", ["--allow-read DIR", "absolute"]),
                ("/nonexistent/x.ron", ["--allow-read DIR", "absolute"]),
            ]
        )
    ],
    case(
        "input_hardening",
        "symlink-out",
        {"secret.ron": "Body(mass: 1.0, inertia: 1.0)", "mech/m.ron": with_part("link.ron")},
        ["bodies[0].part", "symbolic link", "--allow-read DIR"],
        target="mech/m.ron",
        links=[("mech/link.ron", "secret.ron")],
    ),
    case(
        "input_hardening",
        "too-large",
        {"m.ron": GOOD + " " * (1025 - len(GOOD))},
        ["m.ron", "1025 bytes", "limit of 1024 bytes"],
        kind=kanedyn.LimitError,
        flags=["--max-file-kb", "1"],
        kwargs={"max_file_kb": 1},
    ),
    case("input_hardening", "folder", {"d/x.ron": GOOD}, ["not a regular file", "folder"], target="d"),
    case("input_hardening", "dev-zero", {}, ["/dev/zero", "not a regular file"], target="/dev/zero"),
    case(
        "input_hardening",
        "fifo-part",
        {"m.ron": with_part("fifo.ron")},
        ["bodies[0].part", "not a regular file"],
        fifos=["fifo.ron"],
    ),
    case("input_hardening", "echo", {"m.ron": SECRET}, ["m.ron:1:1", "not a `Mechanism` file: it must begin with `Mechanism(`"]),
    case("input_hardening", "echo-part", {"p.ron": SECRET, "m.ron": with_part("p.ron")}, ["p.ron:1:1", "not a `Body` file"]),
    case("input_hardening", "utf8", {"m.ron": b'Mechanism(\n  name: "\xff")'}, ["m.ron:2:10: not UTF-8 text (invalid byte 0xff)"]),
    case(
        "input_hardening",
        "empty",
        {"m.ron": 'Mechanism(name: "m", bodies: [], joints: [])'},
        ["m.ron:1:30 (field `bodies`)", "no bodies: nothing to simulate"],
    ),
    case(
        "input_hardening",
        "too-many-bodies",
        {"m.ron": chain(10_001)},
        ["m.ron:1:34 (field `bodies`)", "10001 bodies", "limit of 1000", "--max-bodies N"],
        kind=kanedyn.LimitError,
        # The file is 1.4 MB: past the default size cap, which would answer first.
        flags=["--max-file-kb", "4096"],
        kwargs={"max_file_kb": 4096},
    ),
    case(
        "input_hardening",
        "too-many-loads",
        {
            "m.ron": 'Mechanism(name: "m", bodies: [Body(name: "a", mass: 1.0)], '
            'joints: [Joint(name: "j", parent: "ground", child: "a")], loads: [%s])'
            % ", ".join(['GroundDamper(body: "a", c: 1.0)'] * 11)
        },
        ["field `loads`", "11 loads", "limit of 10"],
        kind=kanedyn.LimitError,
        flags=["--max-bodies", "1"],
        kwargs={"max_bodies": 1},
    ),
    *[
        case("input_hardening", f"mass-properties-{i}", {"m.ron": one_body(body)}, words)
        for i, (body, words) in enumerate(
            [
                (
                    'Body(name: "b", shape: Disc(radius: 10.0), areal_density: 1e308)',
                    ["m.ron:4:63 (field `bodies[0].areal_density`)", "mass properties overflow", "mass inf kg", "1e308 kg/m²"],
                ),
                ('Body(name: "b", shape: Disc(radius: 1e200), areal_density: 1.0)', ["(field `bodies[0].shape.radius`)", "too large"]),
                (
                    'Body(name: "b", shape: ConvexPolygon(points: [(0.0, 0.0), (1e200, 0.0), (0.0, 1.0)]), areal_density: 1.0)',
                    ["(field `bodies[0].shape.points[1]`)", "too large"],
                ),
                (
                    'Body(name: "b", shape: Compound(parts: [Placed(shape: Disc(radius: 1.0), at: (1e200, 0.0))]), areal_density: 1.0)',
                    ["(field `bodies[0].shape`)", "overflow"],
                ),
                (
                    'Body(name: "b", shape: Disc(radius: 1.0), density: 1e200, thickness: 1e200)',
                    ["m.ron:4:56 (field `bodies[0].density`)", "overflows"],
                ),
                ('Body(name: "b", mass: 1e300, com: (1e200, 0.0))', ["(field `bodies[0].com`)", "overflows"]),
            ]
        )
    ],
    case(
        "input_hardening",
        "mass-matrix-overflow",
        {
            "m.ron": 'Mechanism(name: "m", bodies: [Body(name: "a", mass: 1.0, inertia: 1.0), '
            'Body(name: "b", mass: 1e300, inertia: 1.0)], joints: [Joint(name: "j", parent: "ground", '
            'child: "a"), Joint(name: "k", parent: "a", child: "b", at: (1e200, 0.0))])'
        },
        ["(field `joints[", "not finite"],
    ),
    case(
        "input_hardening",
        "deep-part",
        {"b.ron": deep_part(), "m.ron": with_part("b.ron")},
        ["recursion limit"],
    ),
    case(
        "input_hardening",
        "deep-brackets",
        {"m.ron": 'Mechanism(name: "m", bodies: ' + "[" * 100_000},
        ["m.ron:1:"],
    ),
    case(
        "input_hardening",
        "long-names",
        {
            "m.ron": 'Mechanism(name: "m", bodies: [Body(name: "{n}", mass: 1.0), Body(name: "{n}", mass: 1.0)], '
            "joints: [])".replace("{n}", "n" * (1 << 20))
        },
        ["bodies[1].name", "duplicate body name"],
        flags=["--max-file-kb", "4096"],
        kwargs={"max_file_kb": 4096},
    ),
    # tests/it/joint_kinds.rs, bad kinds
    case(
        "joint_kinds",
        "zero-axis",
        {"m.ron": with_second_joint('Joint(name: "slide", kind: Prismatic(axis: (0.0, 0.0)), parent: "rotor", child: "arm")')},
        ["m.ron:9:", "`joints[1].kind.axis`", "joint `slide`: a prismatic joint needs a finite, non-zero slide axis"],
    ),
    case(
        "joint_kinds",
        "fixed-spring",
        {
            "m.ron": with_second_joint(
                'Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm", spring: Spring(stiffness: 10.0))'
            )
        },
        ["m.ron:9:", "`joints[1].spring`", "joint `weld` is Fixed (welded, no coordinate): it cannot have a spring"],
    ),
    case(
        "joint_kinds",
        "fixed-damper",
        {"m.ron": with_second_joint('Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm", damper: 0.3)')},
        ["m.ron:9:", "`joints[1].damper`", "cannot have a damper"],
    ),
    case(
        "joint_kinds",
        "fixed-torque",
        {
            "m.ron": with_second_joint(
                'Joint(name: "weld", kind: Fixed, parent: "rotor", child: "arm")',
                'JointTorque(joint: "weld", excitation: (mean: 1.0))',
            )
        },
        ["m.ron:11:", "`loads[0].joint`", "joint `weld` is Fixed: it has no coordinate for a torque to drive"],
    ),
    case(
        "joint_kinds",
        "unknown-kind",
        {"m.ron": with_second_joint('Joint(name: "hinge", kind: Helical, parent: "rotor", child: "arm")')},
        ["m.ron:9:", "`joints[1].kind`", "Helical"],
    ),
    case(
        "joint_kinds",
        "all-fixed",
        {
            "m.ron": 'Mechanism(name: "m", bodies: [Body(name: "b", mass: 1.0, inertia: 0.1)], '
            'joints: [Joint(name: "w", kind: Fixed, parent: "ground", child: "b")])'
        },
        ["no coordinate to move"],
    ),
]

if sys.platform == "win32":  # links and FIFOs need a Unix file system
    CASES = [c for c in CASES if not (c.links or c.fifos or c.target == "/dev/zero")]


def assert_located(err):
    """An InputError's attributes rebuild its message: `file:line:column (field `f`): reason`."""
    where = err.file
    if err.line is not None:
        where += f":{err.line}:{err.column}"
    if err.field:
        where += f" (field `{err.field}`)"
    assert str(err) == f"{where}: {err.reason}"


@pytest.mark.parametrize("case", CASES, ids=[f"{c.source}-{c.id}" for c in CASES])
def test_bad_file_raises_the_cli_message(cli, tmp_path, case):
    path = case.write(tmp_path)
    want = cli.error("check", path, *case.flags)
    for words in case.words:
        assert words in want, f"the CLI's message {want[:500]!r} should mention {words!r}"
    with pytest.raises(kanedyn.KanedynError) as e:
        kanedyn.Mechanism.from_file(path, **case.kwargs)
    assert type(e.value) is case.kind, f"{type(e.value).__name__}: {e.value}"
    assert str(e.value) == want
    if issubclass(case.kind, kanedyn.InputError):
        assert_located(e.value)
    if not case.flags:
        # `eom` reads the file by the library's default rules, as Python's defaults do.
        assert cli.error("eom", path, "--q", "0", "--u", "0") == want


# Cases whose file is text; not the size cap, which is about reading a file.
TEXT_CASES = [c for c in CASES if isinstance(c.files.get(c.target), str) and "max_file_kb" not in c.kwargs]


@pytest.mark.parametrize("case", TEXT_CASES, ids=[f"{c.source}-{c.id}" for c in TEXT_CASES])
def test_bad_text_raises_the_same_message(cli, tmp_path, case):
    # Text given with the file's name reads like the file itself (parts from the name's folder).
    path = case.write(tmp_path)
    with pytest.raises(kanedyn.KanedynError) as e:
        kanedyn.Mechanism.from_str(path.read_text(encoding="utf-8"), name=str(path), **case.kwargs)
    assert str(e.value) == cli.error("check", path, *case.flags)


def test_relative_paths_read_as_typed(cli, monkeypatch):
    # tests/it/cli.rs and input_hardening.rs: a missing file, a folder; the OS reason said once.
    monkeypatch.chdir(ROOT)
    for target, kind, words in [
        ("examples/does-not-exist.ron", kanedyn.ReadError, ["examples/does-not-exist.ron", "cannot read"]),
        ("examples", kanedyn.InputError, ["examples", "not a regular file"]),
    ]:
        want = cli.error("check", target)
        assert want.count("os error") <= 1 and "\n" not in want, want
        for words_ in words:
            assert words_ in want
        with pytest.raises(kind) as e:
            kanedyn.Mechanism.from_file(target)
        assert str(e.value) == want
        assert e.value.file == target


def test_policy_keywords_let_outside_parts_in_as_the_flags_do(cli, tmp_path):
    # tests/it/input_hardening.rs: another root, or no restriction, lets the outside part in.
    Case("", {"outside.ron": "Body(mass: 1.0, inertia: 1.0)", "mech/m.ron": with_part("../outside.ron")}, []).write(tmp_path)
    path = tmp_path / "mech" / "m.ron"
    for flags, kwargs in [
        (["--allow-read", tmp_path], {"allow_read": [tmp_path]}),
        (["--allow-read", str(tmp_path)], {"allow_read": [str(tmp_path)]}),
        (["--allow-any-path"], {"allow_any_path": True}),
    ]:
        ok, out, err = cli("check", path, *flags)
        assert ok, err
        assert kanedyn.Mechanism.from_file(path, **kwargs).check()["total_mass"] == 1.0
    with pytest.raises(kanedyn.InputError):
        kanedyn.Mechanism.from_file(path)


def test_every_prefix_of_a_file_loads_or_raises_a_kanedyn_error(cli, tmp_path):
    # The spirit of `locate_never_panics_on_truncated_or_garbled_text`: truncated input is an
    # error with a place, never a panic (InternalError); a sample is checked against the CLI.
    text = GOOD.replace("    ],\n)", '    ],\n    loads: [JointTorque(joint: "spin", excitation: (mean: 1.0))],\n)')
    cuts = [text[:i] for i in range(len(text) + 1)]
    for i, cut in enumerate(cuts):
        try:
            kanedyn.Mechanism.from_str(cut, name="cut.ron")
        except kanedyn.InternalError:  # pragma: no cover - the failure being tested for
            raise
        except kanedyn.KanedynError as e:
            if i % 37 == 0:
                (tmp_path / "cut.ron").write_text(cut)
                assert str(e) == cli.error("check", "cut.ron", cwd=tmp_path)
    kanedyn.Mechanism.from_str(text, name="cut.ron")


def test_the_bad_example_arguments_of_cli_rs_fail_in_python_too(cli):
    # tests/it/cli.rs `bad_input_fails_cleanly`, mechanism part: the file is fine, the state is not.
    mech = kanedyn.Mechanism.from_file(EXAMPLES / "cpva.ron")
    with pytest.raises(kanedyn.ArgumentError, match=r"unknown joint `spn` \(joints: spin, pivot\)"):
        mech.eom([0.0, 0.0], [1.0, 2.0], joint_torques={"spn": 3.0})
    err = cli.error("eom", EXAMPLES / "cpva.ron", "--q", "0,0", "--u", "1,2", "--joint-torque", "spn=3")
    assert "unknown joint `spn`" in err and "spin, pivot" in err
