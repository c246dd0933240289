"""kanedyn: planar multibody dynamics by Kane's method, for torsional vibration.

Load a mechanism, evaluate its equations of motion ``M(q) u̇ = F(q, u, t)``, ``q̇ = W⁻¹ u``, run it
in time, linearise it about a steady spin, continue its periodic steady states by harmonic
balance, or run a whole study file, with NumPy arrays in and out::

    import kanedyn
    m = kanedyn.Mechanism.from_file("examples/cpva.ron")
    M, F, qdot, udot = m.eom([12.5, -0.4], [104.7, -20.0], t=0.0)
    run = kanedyn.simulate(m, [0.0, 0.0, 104.7, 104.7], 0.0, 10.0, [("BodyAccel", "rotor")])
    modes = kanedyn.linearize(m, "spin", 1000.0).modes(spin="held", damped=False)
    branch = kanedyn.hbm_branch(m, "spin", 1000.0, 40.0, 3.3, 2.9)
    result = kanedyn.Study.from_file("examples/cpva_linear.ron").run()
    ron = kanedyn.from_opentorsion(assembly)  # an opentorsion.Assembly, as mechanism RON
    cases = kanedyn.Study.from_file("examples/design_study.ron").run().designs["tuning"]

Design studies can also run on a Dask cluster (``kanedyn.dask.run(study)``, equal bit for bit);
mechanisms and studies pickle (they are rebuilt from their text).

The numbers equal what the ``kanedyn`` command-line tool prints and writes (``kanedyn eom``,
the CSV files and ``results.json`` of ``kanedyn run``), and every error is a
``kanedyn.KanedynError`` carrying the tool's message.
"""

from ._kanedyn import (
    ArgumentError,
    EngineError,
    HbmBranch,
    InputError,
    InternalError,
    KanedynError,
    LimitError,
    LinearModel,
    Mechanism,
    ModelError,
    Modes,
    OrderResponse,
    ReadError,
    Simulation,
    Study,
    StudyResult,
    __version__,
    hbm_branch,
    linearize,
    simulate,
)
from .opentorsion import from_opentorsion

__all__ = [
    "ArgumentError",
    "EngineError",
    "HbmBranch",
    "InputError",
    "InternalError",
    "KanedynError",
    "LimitError",
    "LinearModel",
    "Mechanism",
    "ModelError",
    "Modes",
    "OrderResponse",
    "ReadError",
    "Simulation",
    "Study",
    "StudyResult",
    "__version__",
    "from_opentorsion",
    "hbm_branch",
    "linearize",
    "simulate",
]
