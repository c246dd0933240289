"""kanedyn: planar multibody dynamics by Kane's method, for torsional vibration.

Load a mechanism and evaluate its equations of motion ``M(q) u̇ = F(q, u, t)``, ``q̇ = W⁻¹ u``
as NumPy arrays::

    import kanedyn
    m = kanedyn.Mechanism.from_file("examples/cpva.ron")
    print(m.check()["degrees_of_freedom"])
    M, F, qdot, udot = m.eom([12.5, -0.4], [104.7, -20.0], t=0.0)

The numbers equal what the ``kanedyn`` command-line tool prints (``kanedyn check``,
``kanedyn eom``), and every error is a ``kanedyn.KanedynError`` carrying the tool's message.
"""

from ._kanedyn import (
    ArgumentError,
    EngineError,
    InputError,
    InternalError,
    KanedynError,
    Mechanism,
    ModelError,
    ReadError,
    __version__,
)

__all__ = [
    "ArgumentError",
    "EngineError",
    "InputError",
    "InternalError",
    "KanedynError",
    "Mechanism",
    "ModelError",
    "ReadError",
    "__version__",
]
