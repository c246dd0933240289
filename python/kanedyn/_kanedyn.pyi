"""Type stubs of the native module `kanedyn._kanedyn` (import `kanedyn`, not this module)."""

import os
from typing import Iterable, List, Mapping, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = [
    "__version__",
    "KanedynError",
    "InputError",
    "ReadError",
    "ModelError",
    "EngineError",
    "InternalError",
    "ArgumentError",
    "Mechanism",
    "_panic_for_test",
]

_Path = Union[str, "os.PathLike[str]"]
_Vector = Union[npt.ArrayLike, Sequence[float]]
_Pair = Tuple[float, float]

class KanedynError(Exception):
    """Base class of every error kanedyn raises; `str(err)` is the CLI's message."""

class InputError(KanedynError):
    """Bad input in a mechanism file or text, located at file, line:column and field."""

    file: str
    line: Optional[int]
    column: Optional[int]
    field: str
    reason: str

class ReadError(KanedynError):
    """A file could not be read."""

    file: str

class ModelError(KanedynError):
    """A mechanism that parses but cannot be evaluated."""

    mechanism: str

class EngineError(KanedynError):
    """A failure while evaluating the equations of motion."""

class ArgumentError(KanedynError, ValueError):
    """A bad argument: wrong length, non-finite number, unknown joint."""

class InternalError(KanedynError):
    """A bug in kanedyn: the Rust code panicked."""

class _BodyInfo(TypedDict):
    name: str
    mass: float
    com: _Pair
    inertia: float

class _SpringInfo(TypedDict):
    stiffness: float
    free_angle: float

class _JointInfo(TypedDict):
    name: str
    kind: str
    axis: Optional[_Pair]
    parent: str
    child: str
    at: _Pair
    coordinate: Optional[int]
    unit: Optional[str]
    damper_unit: Optional[str]
    spring_unit: Optional[str]
    damper: float
    spring: Optional[_SpringInfo]

class _LoadsInfo(TypedDict):
    gravity: _Pair
    joint_torques: int
    ground_dampers: int
    point_forces: int

class _CheckInfo(TypedDict):
    name: str
    file: Optional[str]
    degrees_of_freedom: int
    speeds: str
    bodies: List[_BodyInfo]
    joints: List[_JointInfo]
    loads: _LoadsInfo
    total_mass: float

@final
class Mechanism:
    """A validated mechanism: bodies joined in a tree, its generalized speeds and loads."""

    @staticmethod
    def from_file(
        path: _Path,
        *,
        allow_read: Optional[Iterable[_Path]] = None,
        allow_any_path: bool = False,
        max_file_kb: int = 1024,
        max_bodies: int = 1000,
    ) -> "Mechanism":
        """Reads and validates a mechanism file (RON)."""
    @staticmethod
    def from_str(
        text: str,
        name: str = "<string>",
        *,
        allow_read: Optional[Iterable[_Path]] = None,
        allow_any_path: bool = False,
        max_file_kb: int = 1024,
        max_bodies: int = 1000,
    ) -> "Mechanism":
        """Parses and validates mechanism text (RON); `name` stands for the file in messages."""
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> Optional[str]: ...
    @property
    def ndof(self) -> int: ...
    @property
    def coordinate_names(self) -> List[str]: ...
    def check(self) -> _CheckInfo:
        """What `kanedyn check FILE` prints, as a dict."""
    def eom(
        self,
        q: _Vector,
        u: _Vector,
        t: float = 0.0,
        joint_torques: Optional[Mapping[str, float]] = None,
    ) -> Tuple[
        npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]
    ]:
        """`(M, F, qdot, udot)` at one state, bit for bit what `kanedyn eom` prints."""
    def _time_rust_eom(self, q: _Vector, u: _Vector, t: float, calls: int) -> float: ...

def _panic_for_test(message: str) -> None: ...
