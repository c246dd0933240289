"""Type stubs of the native module `kanedyn._kanedyn` (import `kanedyn`, not this module)."""

import os
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = [
    "__version__",
    "KanedynError",
    "InputError",
    "LimitError",
    "ReadError",
    "ModelError",
    "EngineError",
    "InternalError",
    "ArgumentError",
    "Mechanism",
    "simulate",
    "Simulation",
    "linearize",
    "LinearModel",
    "Modes",
    "OrderResponse",
    "hbm_branch",
    "HbmBranch",
    "Study",
    "StudyResult",
    "_opentorsion_ron",
    "_panic_for_test",
]

_Path = Union[str, "os.PathLike[str]"]
_Vector = Union[npt.ArrayLike, Sequence[float]]
_Pair = Tuple[float, float]
_F64 = npt.NDArray[np.float64]
_C128 = npt.NDArray[np.complex128]

class KanedynError(Exception):
    """Base class of every error kanedyn raises; `str(err)` is the CLI's message."""

class InputError(KanedynError):
    """Bad input in a mechanism file or text, located at file, line:column and field."""

    file: str
    line: Optional[int]
    column: Optional[int]
    field: str
    reason: str

class LimitError(InputError):
    """Input refused by a limit that can be raised on purpose (the message names the option)."""

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

class _AbsorberInfo(TypedDict):
    joint: str
    kind: str
    mass: float
    inertia: float
    tuning_order: float
    nonlinear: float
    travel: float
    travel_limit: Optional[float]
    tautochronic: str

class _CheckInfo(TypedDict):
    name: str
    file: Optional[str]
    degrees_of_freedom: int
    speeds: str
    bodies: List[_BodyInfo]
    joints: List[_JointInfo]
    loads: _LoadsInfo
    total_mass: float
    absorbers: List[_AbsorberInfo]

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
    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        """Pickles as its text, file name and read options (rebuilt by `Mechanism.from_str`)."""

@final
class Simulation:
    """The samples of a run: `time` and one array per probe, with how the run ended."""

    @property
    def time(self) -> _F64: ...
    @property
    def names(self) -> List[str]: ...
    @property
    def units(self) -> List[str]: ...
    @property
    def probes(self) -> List[Tuple[str, str]]: ...
    @property
    def columns(self) -> Dict[str, _F64]: ...
    @property
    def completed(self) -> bool: ...
    @property
    def error(self) -> Optional[str]: ...
    @property
    def t_end(self) -> float: ...
    @property
    def x_end(self) -> Optional[_F64]: ...
    @property
    def accepted(self) -> int: ...
    @property
    def rejected(self) -> int: ...
    @property
    def rhs_evals(self) -> int: ...
    @property
    def sample_rhs_evals(self) -> int: ...
    @property
    def samples(self) -> int: ...
    @property
    def wall_s(self) -> float: ...
    def __getitem__(self, key: Union[int, str, Tuple[str, str]], /) -> _F64: ...
    def __len__(self) -> int: ...

def simulate(
    mechanism: Mechanism,
    x0: Union[_Vector, Tuple[_Vector, _Vector]],
    t0: float,
    t1: float,
    probes: Iterable[Tuple[str, str]],
    *,
    rtol: float = 1e-9,
    atol: float = 1e-9,
    sample_hz: Optional[float] = 2000.0,
    max_steps: int = 100_000_000,
    h0: Optional[float] = None,
    h_max: Optional[float] = None,
    joint_torques: Optional[Mapping[str, float]] = None,
) -> Simulation:
    """Integrates from x0 at t0 to t1 (DOP853) and records the probes `(kind, name)`."""

class _OperatingPoint(TypedDict):
    spin_joint: str
    spin_coordinate: int
    omega_rad_s: float
    q: _F64
    u: _F64
    mean_spin_torque: float
    residual: float
    iterations: int

class _RigidMode(TypedDict):
    kind: str
    eigenvalue: complex
    shape_q: _C128
    shape_u: _C128

@final
class Modes:
    """The vibration modes of a linear model, by increasing natural frequency."""

    @property
    def spin(self) -> str: ...
    @property
    def damped(self) -> bool: ...
    @property
    def omega_rad_s(self) -> float: ...
    @property
    def joints(self) -> List[str]: ...
    @property
    def bodies(self) -> List[str]: ...
    @property
    def stable(self) -> bool: ...
    @property
    def orders(self) -> _F64: ...
    @property
    def frequencies_hz(self) -> _F64: ...
    @property
    def natural_frequencies_rad_s(self) -> _F64: ...
    @property
    def damping_ratios(self) -> _F64: ...
    @property
    def eigenvalues(self) -> _C128: ...
    @property
    def labels(self) -> List[str]: ...
    @property
    def shapes_q(self) -> _C128: ...
    @property
    def shapes_qdot(self) -> _C128: ...
    @property
    def shapes_u(self) -> _C128: ...
    @property
    def coordinate_shares(self) -> _F64: ...
    @property
    def body_energy_shares(self) -> _F64: ...
    @property
    def rigid(self) -> List[_RigidMode]: ...
    def __len__(self) -> int: ...

@final
class OrderResponse:
    """The order-domain response (eq. 22) of a body to a unit torque in a joint."""

    @property
    def orders(self) -> _F64: ...
    @property
    def response(self) -> _F64: ...
    @property
    def response_complex(self) -> _C128: ...
    @property
    def locked(self) -> Optional[_F64]: ...
    @property
    def locked_complex(self) -> Optional[_C128]: ...
    @property
    def ratio(self) -> Optional[_F64]: ...
    @property
    def asymptote(self) -> Optional[float]: ...
    @property
    def input_joint(self) -> str: ...
    @property
    def body(self) -> str: ...
    @property
    def lock(self) -> List[str]: ...
    def __len__(self) -> int: ...

@final
class LinearModel:
    """A mechanism linearised about a steady spin."""

    @property
    def rpm(self) -> float: ...
    @property
    def spin_joint(self) -> str: ...
    @property
    def omega_rad_s(self) -> float: ...
    @property
    def coordinate_names(self) -> List[str]: ...
    @property
    def operating_point(self) -> _OperatingPoint: ...
    @property
    def mass(self) -> _F64: ...
    @property
    def f_q(self) -> _F64: ...
    @property
    def f_u(self) -> _F64: ...
    @property
    def f_u_undamped(self) -> _F64: ...
    @property
    def w_inv(self) -> _F64: ...
    def first_order(self, damped: bool = True) -> Tuple[_F64, _F64]:
        """`(M, A)` of eq. (19), `M ẋ + A x = T`."""
    def second_order(self, damped: bool = True) -> Tuple[_F64, _F64, _F64]:
        """`(M, C, K)` of `M q̈ + C q̇ + K q = τ`."""
    def modes(self, spin: str = "free", damped: bool = True) -> Modes:
        """The modes with the spin "free" or "held", with or without the dampers."""
    def order_response(
        self, input_joint: str, body: str, orders: _Vector, lock: Sequence[str] = ()
    ) -> OrderResponse:
        """The response of `body`'s angular acceleration to a unit torque in `input_joint`."""

def linearize(
    mechanism: Mechanism, spin_joint: str, rpm: float, *, guess: Optional[_Vector] = None
) -> LinearModel:
    """Linearises the mechanism about a steady spin of `spin_joint` at `rpm`."""

class _Fold(TypedDict):
    order: float
    kind: str
    after: int
    accel_main: float
    relative_angle: float

class _Bifurcation(TypedDict):
    order: float
    kind: str
    # "fold", "branch point", "period doubling" or "Neimark–Sacker".
    classification: str
    after: int
    gains_stability: bool
    unstable_after: int

@final
class HbmBranch:
    """A branch of periodic steady states, its points in continuation order."""

    @property
    def order(self) -> _F64: ...
    @property
    def multiples(self) -> _F64: ...
    @property
    def accel(self) -> _F64: ...
    @property
    def relative_angle(self) -> _F64: ...
    @property
    def stable(self) -> _F64: ...
    @property
    def max_multiplier(self) -> _F64: ...
    @property
    def mean_torque(self) -> _F64: ...
    @property
    def arclength(self) -> _F64: ...
    @property
    def top_harmonic_ratio(self) -> _F64: ...
    @property
    def folds(self) -> List[_Fold]: ...
    @property
    def bifurcations(self) -> List[_Bifurcation]: ...
    @property
    def end(self) -> str: ...
    @property
    def newton_iterations(self) -> int: ...
    @property
    def wall_s(self) -> float: ...
    @property
    def route(self) -> str: ...
    @property
    def rpm(self) -> float: ...
    @property
    def amplitude(self) -> float: ...
    @property
    def harmonics(self) -> int: ...
    @property
    def body(self) -> str: ...
    def __len__(self) -> int: ...

def hbm_branch(
    mechanism: Mechanism,
    spin_joint: str,
    rpm: float,
    amplitude: float,
    order_from: float,
    order_to: float,
    harmonics: int = 10,
    *,
    body: Optional[str] = None,
    multiples: Sequence[float] = (1.0, 2.0),
    max_step: float = 0.1,
    stability: bool = True,
) -> HbmBranch:
    """Continues the periodic steady state in the excitation order by harmonic balance."""

@final
class StudyResult:
    """The results of a study run: the CSV columns as arrays and the data of results.json."""

    @property
    def status(self) -> str: ...
    @property
    def failures(self) -> List[str]: ...
    @property
    def summary(self) -> str: ...
    @property
    def files(self) -> List[str]: ...
    @property
    def out_dir(self) -> Optional[str]: ...
    @property
    def data(self) -> Dict[str, Any]: ...
    @property
    def tables(self) -> Dict[str, Dict[str, _F64]]: ...
    @property
    def units(self) -> Dict[str, Dict[str, str]]: ...
    @property
    def designs(self) -> Dict[str, Dict[str, npt.NDArray[Any]]]:
        """Each design study's case table: float64 columns, `status` and `error` string arrays."""
    def to_json(self) -> str:
        """The content of results.json."""
    def analysis(self, name: str) -> Dict[str, Any]:
        """One analysis's entry of `data` by name."""

@final
class Study:
    """A study file read and checked whole, ready to run."""

    @staticmethod
    def from_file(
        path: _Path,
        *,
        allow_read: Optional[Iterable[_Path]] = None,
        allow_any_path: bool = False,
        max_file_kb: int = 1024,
        max_bodies: int = 1000,
        max_memory_mb: float = 2048.0,
        max_output_mb: float = 2048.0,
        max_cpu_hours: float = 12.0,
    ) -> "Study":
        """Reads and checks a study file and its mechanism."""
    @staticmethod
    def from_str(
        text: str,
        name: str = "<string>",
        *,
        allow_read: Optional[Iterable[_Path]] = None,
        allow_any_path: bool = False,
        max_file_kb: int = 1024,
        max_bodies: int = 1000,
        max_memory_mb: float = 2048.0,
        max_output_mb: float = 2048.0,
        max_cpu_hours: float = 12.0,
    ) -> "Study":
        """Parses and checks study text; its mechanism is read relative to `name`."""
    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        """Pickles as its text, file name and load options (rebuilt by `Study.from_str`)."""
    @property
    def design_studies(self) -> List[str]: ...
    def design_columns(self, name: str) -> Dict[str, List[Tuple[str, str]]]:
        """`parameters` and `results`: the case table's `(column, unit)` pairs."""
    def case_count(self, name: str) -> int:
        """The number of cases of a design study."""
    def case_values(self, name: str) -> _F64:
        """Every case's parameter values, shape (cases, parameters)."""
    def run_cases(
        self, name: str, indices: Optional[Sequence[int]] = None, *, parallel: bool = True
    ) -> List[Dict[str, Any]]:
        """Runs cases by index: `case`, `values`, `results`, `status`, `error` per case."""
    @property
    def name(self) -> str: ...
    @property
    def file(self) -> str: ...
    @property
    def mechanism(self) -> Mechanism: ...
    @property
    def analyses(self) -> List[Tuple[str, str]]: ...
    def run(self, out: Optional[_Path] = None) -> StudyResult:
        """Runs every analysis; `out` None writes into a temporary folder that is removed."""

def _panic_for_test(message: str) -> None: ...

def _opentorsion_ron(assembly_json: str, name: str) -> str:
    """Mechanism RON of an OpenTorsion assembly in kanedyn's node form; use `from_opentorsion`."""
