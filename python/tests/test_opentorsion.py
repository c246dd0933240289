"""`kanedyn.from_opentorsion` and `kanedyn import` (issue 31, item 6): Gunter & Chen's Example 8.1
(a marine steam-turbine plant with a branched two-stage gearbox) built with the `opentorsion`
package the way its own marine example builds it, converted, and compared with OpenTorsion's
own modal analysis; the same plant as a TORS file through the CLI; a harmonic-balance branch with
a centrifugal pendulum attached by the README's overlay.

Independent references: OpenTorsion's eigenvalues (its own M, K and gear-constraint reduction),
the book's published free modes (177.7, 220.2 and 1282.6 cpm) and the mean-torque balance along
the plant's rigid rotation (closed form below)."""

import json
import shutil

import numpy as np
import pytest

import kanedyn
from conftest import EXAMPLES

ot = pytest.importorskip("opentorsion", reason="opentorsion is installed by run-tests.sh")

TORS = EXAMPLES / "opentorsion_marine.json"
OVERLAY = EXAMPLES / "opentorsion_marine_cpva.ron"
# The book's table is in lb·in·s², lb·in/rad and lb·in·s/rad; this factor takes all three to SI.
F = 0.11298
R_BULL, R_LP, R_HP = 9.4094, 40.0424, 78.2365


def marine_plant():
    """The plant with OpenTorsion's elements, node by node: propeller (0), bull gear (1), the LP
    branch (second-reduction pinion 2, intermediate shaft, first-reduction gear 3, its pinion 4,
    turbine shaft, turbine 5) and the HP branch (6–9)."""
    disks = [
        ot.Disk(0, 2.454e6 * F, c=3.86e6 * F),
        ot.Disk(5, 1.509e4 * F, c=108.77 * F),
        ot.Disk(9, 2.612e2 * F, c=42.738 * F),
    ]
    shafts = [
        ot.Shaft(0, 1, k=826e6 * F, I=0),
        ot.Shaft(2, 3, k=203.94e6 * F, I=0),
        ot.Shaft(4, 5, k=30.51e6 * F, I=0),
        ot.Shaft(6, 7, k=24.17e6 * F, I=0),
        ot.Shaft(8, 9, k=14.26e6 * F, I=0),
    ]
    bull = ot.Gear(1, I=0.826e6 * F, R=R_BULL)
    lp_pinion_2 = ot.Gear(2, I=0, R=1, parent=bull)
    lp_gear_1 = ot.Gear(3, I=1.283e4 * F, R=R_LP)
    lp_pinion_1 = ot.Gear(4, I=0, R=R_BULL, parent=lp_gear_1)
    hp_pinion_2 = ot.Gear(6, I=0, R=1, parent=bull)
    hp_gear_1 = ot.Gear(7, I=2.723e4 * F, R=R_HP)
    hp_pinion_1 = ot.Gear(8, I=0, R=R_BULL, parent=hp_gear_1)
    gears = [bull, lp_pinion_2, lp_gear_1, lp_pinion_1, hp_pinion_2, hp_gear_1, hp_pinion_1]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=gears)


@pytest.fixture(scope="module")
def plant():
    return marine_plant()


@pytest.fixture(scope="module")
def ron(plant):
    return kanedyn.from_opentorsion(plant, "opentorsion_marine")


def test_free_modes_equal_opentorsions_modal_analysis(plant, ron):
    m = kanedyn.Mechanism.from_str(ron, "opentorsion_marine.ron")
    modes = kanedyn.linearize(m, "node_1", 0.0).modes(spin="free", damped=False)
    got = np.asarray(modes.natural_frequencies_rad_s)
    # OpenTorsion's own analyses: the generalised eigenproblem (K, M) after its gear reduction,
    # and its state-space modal analysis without damping (each frequency twice, ± imaginary).
    lam, _ = plant.undamped_modal_analysis()
    w_eig = np.sort(np.sqrt(np.abs(lam.real)))
    wn, _, _ = plant.modal_analysis(C=np.zeros_like(plant.M))
    w_state = np.sort(wn)[::2]
    # One rigid rotation (ω ≈ 0, rounding) and five modes.
    assert w_eig[0] < 1e-6 * w_eig[1] and w_state[0] < 1e-6 * w_state[1]
    assert len(got) == 5 and len(modes.rigid) == 2
    for want in (w_eig[1:], w_state[1:]):
        rel = np.abs(got / want - 1)
        print("kanedyn", got, "OpenTorsion", want, "max relative difference", rel.max())
        assert rel.max() <= 1e-6
    # The book's table (cpm), to its one decimal.
    assert np.abs(got[:3] * 30 / np.pi - [177.7, 220.2, 1282.6]).max() <= 0.05


def test_tors_file_and_kanedyn_import_give_the_same_ron(plant, ron, cli, tmp_path):
    doc = json.loads(TORS.read_text())
    # The file is the same plant by OpenTorsion's own reading of it.
    parsed, _ = ot.Parser.from_tors(doc)
    for a, b in ((parsed.M, plant.M), (parsed.K, plant.K), (parsed.C, plant.C)):
        assert np.array_equal(a, b)
    ok, out, err = cli("import", TORS)
    assert ok, err
    assert out == ron
    assert kanedyn.from_opentorsion(parsed, "opentorsion_marine") == ron
    # And the RON checked in next to the file is this one.
    assert (EXAMPLES / "opentorsion_marine.ron").read_text() == ron
    ok, _, err = cli("import", TORS, "-o", tmp_path / "m.ron", "--name", "opentorsion_marine")
    assert ok, err
    assert (tmp_path / "m.ron").read_text() == ron


def test_harmonic_balance_with_a_cpva_added_by_an_overlay(ron, tmp_path):
    text = OVERLAY.read_text()
    assert len(text.splitlines()) <= 15
    (tmp_path / "opentorsion_marine.ron").write_text(ron)
    shutil.copy(OVERLAY, tmp_path / OVERLAY.name)
    m = kanedyn.Mechanism.from_file(tmp_path / OVERLAY.name)
    assert m.name == "opentorsion_marine_cpva" and m.ndof == 7 and m.coordinate_names[-1] == "pivot"
    absorber = m.check()["absorbers"][0]
    assert absorber["joint"] == "pivot" and abs(absorber["tuning_order"] - 5.0) < 1e-12

    # The propeller's fifth-order torque at the book's resonance speed: 10 % of the full-power
    # torque 22.24e6 lb·in at 85 rpm, following rpm².
    rpm = 35.6
    amplitude = 0.1 * 22.24e6 * F * (rpm / 85.0) ** 2
    b = kanedyn.hbm_branch(m, "node_1", rpm, amplitude, 5.5, 4.5, harmonics=5, body="node_0")
    assert b.end == "ReachedTarget" and len(b) > 10
    assert b.order[0] == 5.5 and abs(b.order[-1] - 4.5) < 1e-9
    assert set(np.unique(b.stable)) <= {0.0, 1.0} and (b.stable == 1).any()
    assert np.all(np.isfinite(b.accel)) and b.relative_angle.max() > 0
    # Along the plant's rigid rotation (the bull gear at Ω, the propeller with it, the LP and HP
    # turbines at R_LP·Ω and R_HP·Ω through both reductions) the inertial and elastic forces
    # average out over a period and the pendulum's damper is internal, so the mean torque at the
    # bull gear pays the ground dampers alone: T_m = Ω Σ c_i r_i².
    omega = rpm * np.pi / 30
    losses = omega * (3.86e6 * F + 108.77 * F * R_LP**2 + 42.738 * F * R_HP**2)
    assert np.abs(b.mean_torque / losses - 1).max() < 1e-8


def test_bad_assemblies_raise_argument_errors(plant):
    bad = marine_plant()
    bad.shaft_elements[2].k = -1.0
    with pytest.raises(kanedyn.ArgumentError, match=r"shaft_elements\[2\].*stiffness must be finite and positive"):
        kanedyn.from_opentorsion(bad)
    bad = marine_plant()
    bad.disk_elements[0].I = float("nan")
    with pytest.raises(kanedyn.ArgumentError, match="not finite"):
        kanedyn.from_opentorsion(bad)
    elastic = ot.Assembly(
        [ot.Shaft(0, 1, k=1e4)],
        disk_elements=[ot.Disk(0, 1.0), ot.Disk(1, 1.0)],
        elastic_gear_elements=[ot.ElasticGear(1, 0.1, 1.0)],
    )
    with pytest.raises(kanedyn.ArgumentError, match="elastic gears are not converted"):
        kanedyn.from_opentorsion(elastic)


def test_a_huge_node_index_is_an_argument_error_not_a_crash():
    """It used to kill the interpreter (issue 49, item 2): a disk at node 10^12 made the importer
    allocate for 10^12 nodes and abort. An index beyond what the elements can hold is now refused
    before anything is sized by it. The assembly is a stand-in with OpenTorsion's attribute names,
    as OpenTorsion's own `Assembly` would size its matrices by that node first."""
    from types import SimpleNamespace as Element

    for node in (10**12, 2**63, 2**64 - 1):
        huge = Element(
            shaft_elements=[],
            disk_elements=[Element(node=0, I=1.0, c=0.0, k=0.0), Element(node=node, I=2.0, c=0.0, k=0.0)],
            gear_elements=[],
        )
        where = rf"assembly\.disk_elements\[1\]\.node: node {node} is beyond the elements"
        with pytest.raises(kanedyn.ArgumentError, match=where):
            kanedyn.from_opentorsion(huge)


def friswell_09_06():
    """OpenTorsion's example `test_friswell_09_06` (Friswell et al., Example 9.6): a chain of nine
    disks on shafts, with springs to ground at nodes 0 and 5 added to `assembly.K` after it was
    built. Returns the assembly, edited, and the two springs."""
    k1, k2, k7, k9 = 10e6, 2.5e6, 40e6, 3e6
    inertias = [90, 140, 140, 140, 140, 90, 350, 500, 22000]
    stiffnesses = [k2, k2, k2, k2, k2, k7, k7, k9]
    disks = [ot.Disk(n, I=i) for n, i in enumerate(inertias)]
    shafts = [ot.Shaft(n, n + 1, None, None, k=k) for n, k in enumerate(stiffnesses)]
    assembly = ot.Assembly(shafts, disk_elements=disks)
    assembly.K[0, 0] += k1
    assembly.K[5, 5] += k1
    return assembly, {0: k1, 5: k1}


def linear_frequencies(mechanism):
    """The natural frequencies (rad/s) of a linear chain from its equations of motion: M and the
    forcing F at rest from `Mechanism.eom`, the stiffness -dF/dq by central differences (exact
    to rounding: F is linear in q here), and the generalised eigenproblem by numpy."""
    n = mechanism.ndof
    zero = np.zeros(n)
    mass, _, _, _ = mechanism.eom(zero, zero)
    stiffness = np.zeros((n, n))
    for j in range(n):
        step = np.zeros(n)
        step[j] = 1e-6
        _, up, _, _ = mechanism.eom(step, zero)
        _, down, _, _ = mechanism.eom(-step, zero)
        stiffness[:, j] = -(np.asarray(up) - np.asarray(down)) / 2e-6
    lam = np.linalg.eigvals(np.linalg.solve(np.asarray(mass), stiffness))
    return np.sort(np.sqrt(np.abs(lam.real)))


def test_an_edited_stiffness_matrix_converts_its_ground_springs():
    """Issue 49, item 10: the springs added to `assembly.K` used to be dropped without a word (the
    elements alone were converted). Now they become springs to ground, and the converted model's
    natural frequencies equal those of the edited K with OpenTorsion's M (numpy on OpenTorsion's
    matrices against numpy on kanedyn's equations of motion; 1e-8 relative, above the central
    differences' rounding on a chain whose inertias span 90 to 22 000 kg·m²)."""
    assembly, springs = friswell_09_06()
    ron = kanedyn.from_opentorsion(assembly, "friswell")
    got = linear_frequencies(kanedyn.Mechanism.from_str(ron, "friswell.ron"))
    lam = np.linalg.eigvals(np.linalg.solve(assembly.M, assembly.K))
    want = np.sort(np.sqrt(lam.real))
    print("kanedyn", got, "OpenTorsion's matrices", want)
    assert len(got) == 9
    assert np.abs(got / want - 1).max() <= 1e-8
    # Without the edit the chain turns freely (a zero frequency): the springs made the difference.
    unedited = ot.Assembly(assembly.shaft_elements, disk_elements=assembly.disk_elements)
    plain = linear_frequencies(kanedyn.Mechanism.from_str(kanedyn.from_opentorsion(unedited, "p"), "p.ron"))
    assert plain[0] < 1e-6 * plain[1] and got[0] > 0.1 * plain[1]
    assert sorted(springs) == [0, 5]


def test_an_edit_that_is_not_a_ground_spring_is_refused_by_entry():
    assembly, _ = friswell_09_06()
    assembly.K[0, 1] -= 1e5
    assembly.K[1, 0] -= 1e5
    with pytest.raises(kanedyn.ArgumentError, match=r"K\[0, 1\] = .* where the elements give -2\.5e\+06; K\[1, 0\]"):
        kanedyn.from_opentorsion(assembly)
    assembly, _ = friswell_09_06()
    assembly.K[3, 3] -= 1e5
    with pytest.raises(kanedyn.ArgumentError, match=r"K\[3, 3\] = 4\.9e\+06 where the elements give 5e\+06"):
        kanedyn.from_opentorsion(assembly)
