"""OpenTorsion assemblies as kanedyn mechanisms: `from_opentorsion(assembly)` gives the mechanism
RON that `kanedyn import` writes for the same model's TORS file (one converter, in Rust: the
assembly is read element by element into kanedyn's node form and handed over as JSON).

The `opentorsion` package is not imported: any object with OpenTorsion's `Assembly` attributes
(`shaft_elements`, `disk_elements`, `gear_elements`) is read.

The elements are what is converted, so a stiffness matrix `assembly.K` edited after the
assembly was built (OpenTorsion's own example `test_friswell_09_06` adds springs to ground that
way) is compared with the one the elements give (`assembly.assemble_K()`): springs to ground
added on the diagonal of an assembly without gears are converted like disks' `k`; any other
edit is refused, naming the entries that differ.
"""

import json
from typing import Any, Dict, List, Optional

from ._kanedyn import ArgumentError, _opentorsion_ron


def _parent_index(gear: Any, i: int, gears: List[Any]) -> Optional[int]:
    """The index in `gears` of gear `i`'s parent, or None."""
    parent = getattr(gear, "parent", None)
    if parent is None:
        return None
    for j, g in enumerate(gears):
        if g is parent:
            return j
    # `Assembly` keeps shallow copies of its gears, whose `parent` is still the original object:
    # find the copy by what the gear stage recorded, the parent's node and radius.
    matches = [j for j, g in enumerate(gears) if j != i and g.node == parent.node and g.R == parent.R]
    if len(matches) != 1:
        raise ArgumentError(
            f"assembly.gear_elements[{i}]: its parent gear (node {parent.node}, R {parent.R}) is "
            f"{'not' if not matches else 'ambiguously'} in the assembly's gear_elements"
        )
    return matches[0]


def _edited_ground_springs(assembly: Any, has_gears: bool) -> List[Dict[str, Any]]:
    """Disks (node, no inertia, `k`) for the springs to ground added to `assembly.K` after it was
    built; `ArgumentError` naming the entries for any edit that is not one (see the module)."""
    stored = getattr(assembly, "K", None)
    rebuild = getattr(assembly, "assemble_K", None)
    # Older OpenTorsion versions assemble K on each call: there is nothing stored to edit.
    if stored is None or callable(stored) or not callable(rebuild):
        return []
    try:
        edited = [[float(v) for v in row] for row in stored]
        built = [[float(v) for v in row] for row in rebuild()]
    except (TypeError, ValueError) as e:
        raise ArgumentError(f"assembly.K: not a matrix of numbers ({e})") from None
    if len(edited) != len(built) or any(len(a) != len(b) for a, b in zip(edited, built)):
        raise ArgumentError(
            f"assembly.K: its shape differs from the {len(built)}×{len(built)} matrix its elements give"
        )
    # Entries the edit did not touch are the same sums in the same order: equal to rounding.
    scale = max((abs(v) for row in built for v in row), default=0.0)
    differ = [
        (i, j, a, b)
        for i, (row_e, row_b) in enumerate(zip(edited, built))
        for j, (a, b) in enumerate(zip(row_e, row_b))
        if not abs(a - b) <= 1e-12 * scale
    ]
    if not differ:
        return []
    convertible = not has_gears and all(i == j and a - b > 0.0 and a - b < float("inf") for i, j, a, b in differ)
    if not convertible:
        shown = "; ".join(f"K[{i}, {j}] = {a:g} where the elements give {b:g}" for i, j, a, b in differ[:6])
        more = f" (and {len(differ) - 6} more)" if len(differ) > 6 else ""
        raise ArgumentError(
            f"assembly.K was edited after the assembly was built: {shown}{more}. Only springs to ground "
            "added on the diagonal of an assembly without gears are converted; add the others as elements "
            "(a disk's `k` is a spring to ground)"
        )
    return [{"node": i, "inertia": 0.0, "c": 0.0, "k": a - b} for i, _, a, b in differ]


def from_opentorsion(assembly: Any, name: str = "opentorsion") -> str:
    """The mechanism RON (text) of an `opentorsion.Assembly`, named `name`.

    Every node is a body; gears become gear couplings, shafts joint springs or compliant
    couplings, disk dampers ground dampers (the RON's comments and the README say how). Load it
    with `kanedyn.Mechanism.from_str(ron, "name.ron")`, or write it to a file and add absorbers
    with an overlay (`base: "name.ron"`). Elastic gears are not converted (`ArgumentError`), nor
    is an edited `assembly.K` other than springs to ground added to its diagonal (see the
    module).
    """
    if getattr(assembly, "elastic_gear_elements", None):
        raise ArgumentError("assembly.elastic_gear_elements: elastic gears are not converted (rigid gears only)")
    shafts = list(getattr(assembly, "shaft_elements", None) or [])
    disks = list(getattr(assembly, "disk_elements", None) or [])
    gears = list(getattr(assembly, "gear_elements", None) or [])
    node_form: Dict[str, List[Dict[str, Any]]] = {
        "shafts": [
            {"nl": int(s.nl), "nr": int(s.nr), "k": float(s.k), "c": float(s.c), "mass": float(s.mass)}
            for s in shafts
        ],
        "disks": [
            {"node": int(d.node), "inertia": float(d.I), "c": float(d.c), "k": float(d.k)} for d in disks
        ],
        "gears": [
            {"node": int(g.node), "inertia": float(g.I), "radius": float(g.R), "parent": _parent_index(g, i, gears)}
            for i, g in enumerate(gears)
        ],
    }
    try:
        text = json.dumps(node_form, allow_nan=False)
    except ValueError:
        raise ArgumentError("the assembly has a number that is not finite (NaN or infinity)") from None
    # The elements are checked first: an element edited after the build (a negative stiffness)
    # also makes the stored K differ from the elements', and its own error names it.
    ron = _opentorsion_ron(text, name)
    extra = _edited_ground_springs(assembly, bool(gears))
    if not extra:
        return ron
    node_form["disks"] += extra
    return _opentorsion_ron(json.dumps(node_form, allow_nan=False), name)
