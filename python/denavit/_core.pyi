"""Type stubs of the compiled extension `denavit._core` (the Rust core's binding).

Frames and units: docs/conventions.md. SI inside (m, rad); poses are (4, 4) float64 arrays `T_a_b`.
Errors are `denavit.errors.DenavitError` (or a subclass) carrying the core error's fields (`kind`, `what`,
`expected`, `got`, `index`, ...). Every class pickles and deep-copies. tests/test_binding.py checks this stub
against the module (names, kinds and parameter names).
"""

from collections.abc import Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__version__: str

class Model:
    """An immutable serial chain (docs/conventions.md, "The model")."""
    @staticmethod
    def from_placements(
        placements: ArrayLike,
        kinds: Sequence[str],
        *,
        offsets: ArrayLike | None = None,
        lower: ArrayLike | None = None,
        upper: ArrayLike | None = None,
        names: Sequence[str] | None = None,
        T_world_base: ArrayLike | None = None,
        T_last_flange: ArrayLike | None = None,
        T_flange_tool: ArrayLike | None = None,
        name: str = "robot",
        dh_link_frames: ArrayLike | None = None,
    ) -> Model:
        """dh_link_frames: (n, 4, 4) standard-DH frame i in joint frame i (recorded by Table("dh", ...).to_model())."""
    @property
    def nq(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def kinds(self) -> list[str]: ...
    @property
    def placements(self) -> NDArray[np.float64]: ...
    @property
    def offsets(self) -> NDArray[np.float64]: ...
    @property
    def lower(self) -> NDArray[np.float64]: ...
    @property
    def upper(self) -> NDArray[np.float64]: ...
    @property
    def dh_link_frames(self) -> NDArray[np.float64] | None:
        """(n, 4, 4) standard-DH frame i in joint frame i for a model built from a DH table, else None."""
    @property
    def T_world_base(self) -> NDArray[np.float64]: ...
    @property
    def T_last_flange(self) -> NDArray[np.float64]:
        """The flange (mechanical flange, ROS tool0) in the last joint frame."""
    @property
    def T_flange_tool(self) -> NDArray[np.float64]: ...
    @property
    def T_last_tool(self) -> NDArray[np.float64]:
        """The tool in the last joint frame: T_last_flange @ T_flange_tool."""
    def with_base(self, T_world_base: ArrayLike) -> Model: ...
    def with_tool(self, T_flange_tool: ArrayLike) -> Model: ...
    def with_inertias(
        self,
        masses: ArrayLike,
        coms: ArrayLike,
        inertias: ArrayLike,
        frame: str = "link",
        about: str = "com",
        q_ref: ArrayLike | None = None,
    ) -> Model:
        """A copy with link inertial parameters: masses (n,) kg, coms (n, 3) m, inertias (n, 3, 3) kg m^2 about each
        centre of mass (about="com") or the frame origin (about="origin"); frame="link": link i in joint frame i
        (dv.joint_frames), frame="dh": link i in standard-DH frame i (joint frame i @ Tz(d) Tx(a) Rx(alpha), the frame
        of
        published DH inertia tables; a model built from a DH table), frame="world": in world with the robot at q_ref
        (default zeros). An error about one link sets e.joint."""
    @property
    def inertias(self) -> dict[str, NDArray[np.float64]]:
        """{"masses": (n,), "coms": (n, 3), "inertias": (n, 3, 3)}, link i in joint frame i, about each centre of
        mass."""

class Table:
    """A parameter table of one convention: dh (d, theta, a, alpha), mdh (alpha, a, theta, d),
    edh (alpha, a, b, c, theta), poe (wx, wy, wz, vx, vy, vz)."""
    def __init__(
        self,
        convention: str,
        params: ArrayLike,
        kinds: Sequence[str] | None = None,
        T_world_base: ArrayLike | None = None,
        T_last_tool: ArrayLike | None = None,
    ) -> None: ...
    @property
    def convention(self) -> str: ...
    @property
    def columns(self) -> list[str]: ...
    @property
    def angle_columns(self) -> list[bool]: ...
    @property
    def params(self) -> NDArray[np.float64]: ...
    @property
    def kinds(self) -> list[str]: ...
    @property
    def T_world_base(self) -> NDArray[np.float64]: ...
    @property
    def T_last_tool(self) -> NDArray[np.float64]: ...
    def to_model(
        self,
        name: str = "robot",
        names: Sequence[str] | None = None,
        lower: ArrayLike | None = None,
        upper: ArrayLike | None = None,
    ) -> Model: ...
    def link_frames(self) -> NDArray[np.float64]:
        """(n, 4, 4): the convention's frame i in the model's joint frame i."""
    def frames(self, q: ArrayLike) -> NDArray[np.float64]: ...

class JointAxes:
    """Joint axis lines in world at a reference configuration."""
    def __init__(
        self,
        points: ArrayLike,
        directions: ArrayLike,
        *,
        kinds: Sequence[str] | None = None,
        q_ref: ArrayLike | None = None,
        T_world_base: ArrayLike | None = None,
        T_world_tool: ArrayLike | None = None,
        lower: ArrayLike | None = None,
        upper: ArrayLike | None = None,
    ) -> None: ...
    @property
    def nq(self) -> int: ...
    @property
    def points(self) -> NDArray[np.float64]: ...
    @property
    def directions(self) -> NDArray[np.float64]: ...
    @property
    def kinds(self) -> list[str]: ...
    @property
    def q_ref(self) -> NDArray[np.float64]: ...
    @property
    def lower(self) -> NDArray[np.float64]: ...
    @property
    def upper(self) -> NDArray[np.float64]: ...
    @property
    def T_world_base(self) -> NDArray[np.float64]: ...
    @property
    def T_world_tool(self) -> NDArray[np.float64]: ...

class PairDiagnostic:
    """One consecutive pair of axes as seen by an extraction."""
    def __init__(self, joint: int, relation: str, angle: float, distance: float, hayati_beta: float) -> None: ...
    joint: int
    relation: str
    angle: float
    distance: float
    hayati_beta: float

class Extraction:
    """The result of an extraction: the table and what it cannot represent."""
    def __init__(
        self, table: Table, pairs: Sequence[PairDiagnostic], max_position_error: float, max_rotation_error: float
    ) -> None: ...
    table: Table
    pairs: list[PairDiagnostic]
    max_position_error: float
    max_rotation_error: float

def axes(model: Model, q: ArrayLike) -> JointAxes: ...
def extract(
    axes: JointAxes,
    convention: str,
    *,
    parallel_tol: float = 1e-3,
    intersect_tol: float = 1e-9,
    max_offset: float | None = None,
    nominal: Table | None = None,
    origins: ArrayLike | None = None,
    fidelity: bool = True,
) -> Extraction: ...
def fk(model: Model, q: ArrayLike) -> NDArray[np.float64]: ...
def joint_frames(model: Model, q: ArrayLike) -> NDArray[np.float64]: ...
def jacobian(
    model: Model, q: ArrayLike, frame: str = "local_world_aligned", joint: int | str | None = None
) -> NDArray[np.float64]:
    """(6, n), rows [v; w], of the tool (joint=None) or of joint frame `joint` (1-based number or name; later columns
    zero). frame: "local" (the frame's origin and axes, pinocchio LOCAL), "local_world_aligned" (its origin, world
    axes), "world" (spatial velocity at the world origin, pinocchio WORLD), "base" (its origin, base axes)."""

# Batches: qs (N, n) row-major. out=: a C-contiguous, writeable float64 array of the result's shape, filled and
# returned (no allocation). threads=: None = RAYON_NUM_THREADS, else every core; 1 = serially on the calling
# thread; k = a pool of k threads built once and cached. The GIL is released while the kernel runs (docs/speed.md).
def fk_batch(
    model: Model, qs: ArrayLike, *, out: NDArray[np.float64] | None = None, threads: int | None = None
) -> NDArray[np.float64]: ...
def jacobian_batch(
    model: Model,
    qs: ArrayLike,
    frame: str = "local_world_aligned",
    joint: int | str | None = None,
    *,
    out: NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> NDArray[np.float64]: ...

# Dynamics (Featherstone 2008). Gravity in world, m/s^2 (default [0, 0, -9.81]); f_ext = wrench [fx, fy, fz, nx, ny, nz]
# (N, N m) applied to the tool by the environment, tool-frame axes, moment about the tool origin; efforts in N m / N.
def rnea(
    model: Model,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    gravity: ArrayLike | None = None,
    f_ext: ArrayLike | None = None,
) -> NDArray[np.float64]: ...
def bias_forces(model: Model, q: ArrayLike, qd: ArrayLike, gravity: ArrayLike | None = None) -> NDArray[np.float64]: ...
def gravity_torques(model: Model, q: ArrayLike, gravity: ArrayLike | None = None) -> NDArray[np.float64]: ...
def mass_matrix(model: Model, q: ArrayLike) -> NDArray[np.float64]: ...
def coriolis_matrix(model: Model, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]: ...
def forward_dynamics(
    model: Model,
    q: ArrayLike,
    qd: ArrayLike,
    tau: ArrayLike,
    gravity: ArrayLike | None = None,
    f_ext: ArrayLike | None = None,
    method: str = "aba",
) -> NDArray[np.float64]: ...
def kinetic_energy(model: Model, q: ArrayLike, qd: ArrayLike) -> float: ...
def potential_energy(model: Model, q: ArrayLike, gravity: ArrayLike | None = None) -> float: ...
def rnea_batch(
    model: Model,
    qs: ArrayLike,
    qds: ArrayLike,
    qdds: ArrayLike,
    gravity: ArrayLike | None = None,
    f_ext: ArrayLike | None = None,
    *,
    out: NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> NDArray[np.float64]: ...
def bias_forces_batch(
    model: Model,
    qs: ArrayLike,
    qds: ArrayLike,
    gravity: ArrayLike | None = None,
    *,
    out: NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> NDArray[np.float64]: ...
def gravity_torques_batch(
    model: Model,
    qs: ArrayLike,
    gravity: ArrayLike | None = None,
    *,
    out: NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> NDArray[np.float64]: ...
def mass_matrix_batch(
    model: Model, qs: ArrayLike, *, out: NDArray[np.float64] | None = None, threads: int | None = None
) -> NDArray[np.float64]: ...
def coriolis_matrix_batch(
    model: Model, qs: ArrayLike, qds: ArrayLike, *, out: NDArray[np.float64] | None = None, threads: int | None = None
) -> NDArray[np.float64]: ...
def forward_dynamics_batch(
    model: Model,
    qs: ArrayLike,
    qds: ArrayLike,
    taus: ArrayLike,
    gravity: ArrayLike | None = None,
    f_ext: ArrayLike | None = None,
    *,
    out: NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> NDArray[np.float64]: ...
def transfer_inertias(source: Model, target: Model, q_ref: ArrayLike | None = None) -> Model: ...

# Inverse kinematics (Newton-Raphson as in Guo et al. sec. V; Levenberg-Marquardt / damped least squares).
# Success is decided from the measured final errors: position_error (m) <= tol_position and rotation_error (rad)
# <= tol_rotation (and q within the limits when respect_limits). Restarts are seeded (deterministic).
class IkResult:
    """One IK solve; the errors are measured at the returned q."""
    def __init__(
        self, q: ArrayLike, success: bool, iterations: int, restarts: int, position_error: float, rotation_error: float
    ) -> None: ...
    @property
    def q(self) -> NDArray[np.float64]: ...
    @property
    def success(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def restarts(self) -> int: ...
    @property
    def position_error(self) -> float: ...
    @property
    def rotation_error(self) -> float: ...

class IkBatchResult:
    """Results of ik_path / ik_batch as arrays; also a sequence of IkResult."""
    def __init__(self, results: Sequence[IkResult], nq: int) -> None:
        """results: the IkResult of each goal, in order; nq: joints (the width of `q` when there are none)."""
    @property
    def q(self) -> NDArray[np.float64]: ...
    @property
    def success(self) -> NDArray[np.bool_]: ...
    @property
    def iterations(self) -> NDArray[np.int64]: ...
    @property
    def restarts(self) -> NDArray[np.int64]: ...
    @property
    def position_error(self) -> NDArray[np.float64]: ...
    @property
    def rotation_error(self) -> NDArray[np.float64]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, key: int, /) -> IkResult: ...
    def __iter__(self) -> Iterator[IkResult]: ...

def ik(
    model: Model,
    T_goal: ArrayLike,
    q0: ArrayLike | None = None,
    *,
    method: str = "lm",
    tol_position: float = 1e-10,
    tol_rotation: float = 1e-10,
    max_iterations: int = 100,
    restarts: int = 50,
    seed: int = 0,
    respect_limits: bool = True,
    damping: float = 0.1,
) -> IkResult: ...
def ik_path(
    model: Model,
    goals: ArrayLike,
    q0: ArrayLike | None = None,
    *,
    method: str = "lm",
    tol_position: float = 1e-10,
    tol_rotation: float = 1e-10,
    max_iterations: int = 100,
    restarts: int = 50,
    seed: int = 0,
    respect_limits: bool = True,
    damping: float = 0.1,
) -> IkBatchResult: ...
def ik_batch(
    model: Model,
    goals: ArrayLike,
    q0s: ArrayLike | None = None,
    *,
    method: str = "lm",
    tol_position: float = 1e-10,
    tol_rotation: float = 1e-10,
    max_iterations: int = 100,
    restarts: int = 50,
    seed: int = 0,
    respect_limits: bool = True,
    damping: float = 0.1,
    threads: int | None = None,
) -> IkBatchResult: ...

class CalibrationChain:
    """A chain of elementary factors with named parameters (built by `denavit.calibration`).

    axes: K of "rx" | "ry" | "rz" | "tx" | "ty" | "tz" | "fixed"; params: K parameter indices (ignored for
    "fixed"); joints: K 0-based joints whose reading adds to the value (-1: none); fixed: (F, 4, 4) the fixed
    poses in the order of the "fixed" entries; scales: nq indices of each joint's scale parameter (-1: none).
    """
    def __init__(
        self,
        axes: Sequence[str],
        params: Sequence[int],
        joints: Sequence[int],
        fixed: ArrayLike,
        n_params: int,
        nq: int,
        scales: Sequence[int],
    ) -> None: ...
    @property
    def n_params(self) -> int: ...
    @property
    def nq(self) -> int: ...
    def evaluate(
        self,
        x: ArrayLike,
        qs: ArrayLike,
        jacobian: bool = True,
        *,
        rows: int = 6,
        columns: Sequence[int] | None = None,
        weights: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Tool poses (N, 4, 4) and, if `jacobian`, identification Jacobians (N, rows, len(columns)), rows [v; w] in
        world, of the parameters `columns` (default all), each row times its `weights` entry."""

def convention_info(name: str) -> dict: ...
def conventions() -> list[str]: ...
def default_limits(kind: str) -> tuple[float, float]: ...

NEAR_PARALLEL_SIN: float
EXACT_PARALLEL_SIN: float

def parametrize(
    table: Table,
    T_last_flange: ArrayLike,
    T_flange_tool: ArrayLike,
    measure: str = "point",
    scale: bool = False,
    robot: str = "robot",
) -> dict: ...

class Compensation:
    """The compensation of N positions: per position the identified and nominal joint values, the command, the flags."""
    def __init__(
        self,
        q: ArrayLike,
        q_nominal: ArrayLike,
        commands: ArrayLike,
        reached: Sequence[bool],
        nominal_reached: Sequence[bool],
        branch_changed: Sequence[bool],
        path_jump: Sequence[bool],
        position_error: Sequence[float],
        rotation_error: Sequence[float],
        before_position: Sequence[float],
        before_rotation: Sequence[float],
    ) -> None: ...
    def __len__(self) -> int: ...
    @property
    def q(self) -> NDArray[np.float64]: ...
    @property
    def q_nominal(self) -> NDArray[np.float64]: ...
    @property
    def commands(self) -> NDArray[np.float64]: ...
    @property
    def reached(self) -> NDArray[np.bool_]: ...
    @property
    def nominal_reached(self) -> NDArray[np.bool_]: ...
    @property
    def branch_changed(self) -> NDArray[np.bool_]: ...
    @property
    def path_jump(self) -> NDArray[np.bool_]: ...
    @property
    def position_error(self) -> NDArray[np.float64]: ...
    @property
    def rotation_error(self) -> NDArray[np.float64]: ...
    @property
    def before_position(self) -> NDArray[np.float64]: ...
    @property
    def before_rotation(self) -> NDArray[np.float64]: ...

def compensate(
    nominal: Model,
    identified: Model,
    positions: ArrayLike,
    q_nominal: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    *,
    path: bool = False,
    branch_tol: float = 0.1,
    path_jump: float = ...,
    method: str = "lm",
    tol_position: float = 1e-10,
    tol_rotation: float = 1e-10,
    max_iterations: int = 100,
    restarts: int = 50,
    seed: int = 0,
    respect_limits: bool = True,
    damping: float = 0.1,
) -> Compensation: ...
