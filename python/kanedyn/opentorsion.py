"""OpenTorsion assemblies as kanedyn mechanisms: `from_opentorsion(assembly)` gives the mechanism
RON that `kanedyn import` writes for the same model's TORS file (one converter, in Rust: the
assembly is read element by element into kanedyn's node form and handed over as JSON).

The `opentorsion` package is not imported: any object with OpenTorsion's `Assembly` attributes
(`shaft_elements`, `disk_elements`, `gear_elements`) is read.
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


def from_opentorsion(assembly: Any, name: str = "opentorsion") -> str:
    """The mechanism RON (text) of an `opentorsion.Assembly`, named `name`.

    Every node is a body; gears become gear couplings, shafts joint springs or compliant
    couplings, disk dampers ground dampers (the RON's comments and the README say how). Load it
    with `kanedyn.Mechanism.from_str(ron, "name.ron")`, or write it to a file and add absorbers
    with an overlay (`base: "name.ron"`). Elastic gears are not converted (`ArgumentError`).
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
    return _opentorsion_ron(text, name)
