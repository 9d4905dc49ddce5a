"""Type stubs of tetfem's native module (``tetfem._tetfem``); see the docstrings for units."""

from os import PathLike
from typing import Any, final, Callable, Dict, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
STATIC_TIME: float
__all__ = [
    "Mesh",
    "Material",
    "MaterialMap",
    "Constraints",
    "Loads",
    "StaticResult",
    "StaticSolver",
    "Obstacle",
    "Amplitude",
    "Simulation",
    "ModalResult",
    "solve_static",
    "solve_static_mixed",
    "mixed_modal_analysis",
    "mixed_transient",
    "mixed_neo_hookean_transient",
    "modal_analysis",
    "run_scene",
    "stiffness_matrix",
    "mass_matrix",
    "estimate_error",
    "model_advice",
    "STATIC_TIME",
    "__version__",
]

_ArrayLike = npt.ArrayLike
_FloatArray = npt.NDArray[np.float64]
_IndexArray = npt.NDArray[np.int64]
# The names each option accepts (an InvalidInputError lists them for any other value).
_Axis = Union[Literal[0, 1, 2], Literal["x", "y", "z", "X", "Y", "Z"]]
# Any non-empty set of axes, each letter once (the module also takes upper case and repeats).
_Axes = Literal[
    "x", "y", "z", "xy", "xz", "yx", "yz", "zx", "zy", "xyz", "xzy", "yxz", "yzx", "zxy", "zyx"
]
_Split = Literal["mirrored6", "lecture6", "five"]
_Method = Literal["backward-euler", "backward_euler", "newmark", "explicit"]
_Model = Literal[
    "linear", "corotational", "neo-hookean", "neo_hookean", "st-venant-kirchhoff", "st_venant_kirchhoff"
]
_Mass = Literal["lumped", "consistent"]
_LinearSolver = Literal["auto", "direct", "iterative"]
_NonlinearSolver = Literal["auto", "rest_lbfgs", "rest_preconditioned", "refactor"]
_Path = Union[str, "PathLike[str]"]
# A scipy.sparse.csr_matrix when SciPy is installed, else (indptr, indices, data, shape).
_SparseMatrix = Any

@final
class Amplitude:
    @staticmethod
    def constant(value: float) -> "Amplitude": ...
    @staticmethod
    def table(points: _ArrayLike, values: Optional[_ArrayLike] = None) -> "Amplitude": ...
    @staticmethod
    def ramp(start: float = 0.0, end: float = 1.0) -> "Amplitude": ...
    @staticmethod
    def smooth_step(start: float = 0.0, end: float = 1.0) -> "Amplitude": ...
    @staticmethod
    def sine(amplitude: float, frequency: float, phase: float = 0.0, start: float = 0.0) -> "Amplitude": ...
    def value(self, t: Any) -> Any: ...  # float for a float, an array for an array
    def rate(self, t: Any) -> Any: ...
    def acceleration(self, t: Any) -> Any: ...
    @property
    def is_constant(self) -> bool: ...

# An amplitude= keyword: an Amplitude, a constant, or (k, 2) rows of (t, a) (a table).
_AmplitudeLike = Union[Amplitude, float, _ArrayLike, None]

@final
class Mesh:
    def __new__(
        cls, points: _ArrayLike, tets: _ArrayLike, groups: Optional[List[Dict[str, Any]]] = None
    ) -> "Mesh": ...
    @staticmethod
    def box(
        max: _ArrayLike,
        cells: _ArrayLike,
        min: Optional[_ArrayLike] = None,
        split: _Split = "mirrored6",
        order: Literal[1, 2] = 1,
    ) -> "Mesh": ...
    @staticmethod
    def read(path: _Path, order: Optional[Literal[1, 2]] = None) -> "Mesh": ...
    @property
    def order(self) -> Literal[1, 2]: ...
    @property
    def points(self) -> _FloatArray: ...
    @staticmethod
    def bodies(
        meshes: List["Mesh"],
        translations: Optional[_ArrayLike] = None,
        rotations: Optional[List[Optional[Tuple[_ArrayLike, float]]]] = None,
    ) -> "Mesh": ...
    @property
    def body_of_node(self) -> Optional[_IndexArray]: ...
    @property
    def body_of_tet(self) -> Optional[_IndexArray]: ...
    @property
    def tets(self) -> _IndexArray: ...
    @property
    def node_count(self) -> int: ...
    @property
    def tet_count(self) -> int: ...
    @property
    def dof_count(self) -> int: ...
    @property
    def volume(self) -> float: ...
    @property
    def reoriented_count(self) -> int: ...
    @property
    def bounding_box(self) -> Tuple[_FloatArray, _FloatArray]: ...
    @property
    def groups(self) -> List[Dict[str, Any]]: ...
    @property
    def warnings(self) -> List[str]: ...
    def nodes_on_plane(self, axis: _Axis, at: float, tolerance: Optional[float] = None) -> _IndexArray: ...
    def nodes_in_box(self, min: _ArrayLike, max: _ArrayLike) -> _IndexArray: ...
    def nodes_where(self, mask: _ArrayLike) -> _IndexArray: ...
    def nodes_in_group(self, name: str) -> _IndexArray: ...
    def nodes_with_marker(self, marker: int) -> _IndexArray: ...
    def nodes_with_face_marker(self, marker: int) -> _IndexArray: ...
    def faces_with_marker(self, marker: int) -> _IndexArray: ...
    def tets_in_box(self, min: _ArrayLike, max: _ArrayLike) -> _IndexArray: ...
    def tets_in_group(self, name: str) -> _IndexArray: ...
    def tets_with_attribute(self, value: float) -> _IndexArray: ...
    def boundary_faces(self) -> _IndexArray: ...
    def faces_of_nodes(self, nodes: _ArrayLike) -> _IndexArray: ...
    def faces_on_plane(self, axis: _Axis, at: float, tolerance: Optional[float] = None) -> _IndexArray: ...
    def faces_in_box(self, min: _ArrayLike, max: _ArrayLike) -> _IndexArray: ...
    def faces_where(self, mask: _ArrayLike) -> _IndexArray: ...
    def faces_in_group(self, name: str) -> _IndexArray: ...
    @staticmethod
    def from_meshio(mesh: Any) -> "Mesh": ...
    def to_meshio(self, point_data: Optional[Dict[str, Any]] = None, cell_data: Optional[Dict[str, Any]] = None) -> Any: ...

@final
class Material:
    def __new__(cls, youngs_modulus: float, poisson_ratio: float, density: float) -> "Material": ...
    @staticmethod
    def steel() -> "Material": ...
    @property
    def youngs_modulus(self) -> float: ...
    @property
    def poisson_ratio(self) -> float: ...
    @property
    def density(self) -> float: ...
    @property
    def lame_lambda(self) -> float: ...
    @property
    def shear_modulus(self) -> float: ...
    @property
    def bulk_modulus(self) -> float: ...
    @property
    def p_wave_speed(self) -> float: ...

@final
class MaterialMap:
    def __new__(
        cls,
        materials: Sequence[Material],
        of_tet: _ArrayLike,
        names: Optional[Sequence[str]] = None,
    ) -> "MaterialMap": ...
    @property
    def materials(self) -> List[Material]: ...
    @property
    def names(self) -> List[str]: ...
    @property
    def of_tet(self) -> _IndexArray: ...

_Materials = Union[Material, MaterialMap]

@final
class Constraints:
    def __new__(cls, mesh: Mesh) -> "Constraints": ...
    def fix(self, nodes: _ArrayLike, axes: _Axes = "xyz") -> "Constraints": ...
    def prescribe(
        self, nodes: _ArrayLike, displacement: _ArrayLike, axes: _Axes = "xyz", amplitude: _AmplitudeLike = None
    ) -> "Constraints": ...
    def prescribe_linear(
        self,
        nodes: _ArrayLike,
        gradient: _ArrayLike,
        offset: Optional[_ArrayLike] = None,
        amplitude: _AmplitudeLike = None,
    ) -> "Constraints": ...
    def prescribe_rigid(
        self,
        nodes: _ArrayLike,
        axis: Optional[_ArrayLike] = None,
        point: Optional[_ArrayLike] = None,
        angle: float = 0.0,
        translation: Optional[_ArrayLike] = None,
        amplitude: _AmplitudeLike = None,
        axes: _Axes = "xyz",
    ) -> "Constraints": ...
    @property
    def count(self) -> int: ...
    @property
    def constrained_dofs(self) -> _IndexArray: ...

@final
class Loads:
    def __new__(cls, mesh: Mesh) -> "Loads": ...
    def add_gravity(
        self, acceleration: _ArrayLike, material: _Materials, amplitude: _AmplitudeLike = None
    ) -> "Loads": ...
    def add_body_force(self, force_density: _ArrayLike, amplitude: _AmplitudeLike = None) -> "Loads": ...
    def add_traction(self, faces: _ArrayLike, traction: _ArrayLike, amplitude: _AmplitudeLike = None) -> "Loads": ...
    def add_total_force(self, faces: _ArrayLike, force: _ArrayLike, amplitude: _AmplitudeLike = None) -> "Loads": ...
    def add_pressure(self, faces: _ArrayLike, pressure: float, amplitude: _AmplitudeLike = None) -> "Loads": ...
    def add_nodal_force(self, nodes: _ArrayLike, force: _ArrayLike, amplitude: _AmplitudeLike = None) -> "Loads": ...
    @property
    def forces(self) -> _FloatArray: ...
    @property
    def gravity(self) -> _FloatArray: ...
    @property
    def resultant(self) -> _FloatArray: ...

@final
class Obstacle:
    @staticmethod
    def half_space(name: str, point: _ArrayLike, normal: _ArrayLike, friction: float = 0.0) -> Obstacle: ...
    @staticmethod
    def sphere(name: str, center: _ArrayLike, radius: float, friction: float = 0.0) -> Obstacle: ...
    @staticmethod
    def box(name: str, min: _ArrayLike, max: _ArrayLike, friction: float = 0.0) -> Obstacle: ...
    def moving(
        self,
        *,
        velocity: Optional[_ArrayLike] = None,
        displacement: Optional[_ArrayLike] = None,
        amplitude: _AmplitudeLike = None,
    ) -> Obstacle: ...
    def spinning(
        self, omega: _ArrayLike, axis_point: Optional[_ArrayLike] = None
    ) -> Obstacle: ...
    @property
    def spin(self) -> Optional[_FloatArray]: ...
    def offset(self, t: float) -> _FloatArray: ...
    @property
    def is_moving(self) -> bool: ...
    @property
    def name(self) -> str: ...
    @property
    def friction(self) -> float: ...
    def distance(self, point: _ArrayLike) -> float: ...

@final
class StaticResult:
    displacement: _FloatArray
    stress: _FloatArray
    von_mises: _FloatArray
    reactions: _FloatArray
    contact_forces: Optional[_FloatArray]
    relative_residual: float
    model: str
    solver: str
    def mean_displacement(self, nodes: _ArrayLike) -> _FloatArray: ...

@final
class StaticSolver:
    def __new__(
        cls, mesh: Mesh, material: _Materials, constraints: Constraints, linear_solver: _LinearSolver = "auto"
    ) -> "StaticSolver": ...
    def solve(self, loads: Loads) -> StaticResult: ...
    def stiffness(self) -> _SparseMatrix: ...
    def free_stiffness(self) -> _SparseMatrix: ...
    @property
    def free_dofs(self) -> _IndexArray: ...
    @property
    def factor_len(self) -> int: ...

@final
class ModalResult:
    frequencies: _FloatArray
    omega: _FloatArray
    shapes: _FloatArray
    residuals: _FloatArray
    iterations: int

@final
class Simulation:
    def __new__(
        cls,
        mesh: Mesh,
        material: _Materials,
        constraints: Constraints,
        loads: Optional[Loads] = None,
        *,
        dt: Union[float, str],
        method: _Method = "backward-euler",
        model: Union[_Model, Sequence[_Model]] = ...,  # "linear"; or one per material
        mass: _Mass = "lumped",
        damping: Tuple[float, float] = ...,  # (0.0, 0.0): no damping
        initial_displacement: Optional[_ArrayLike] = None,
        initial_velocity: Optional[_ArrayLike] = None,
        linear_solver: _LinearSolver = "auto",
        nonlinear_solver: _NonlinearSolver = "auto",
        newton_tolerance: Optional[float] = None,  # in (0, 1); None: 1e-8
        relax_contact_nodes: bool = True,
        obstacles: Optional[Sequence[Obstacle]] = None,
        contact_distance: Optional[float] = None,
        contact_stiffness: Optional[float] = None,
        contact_impact_fraction: Optional[float] = None,  # f in (0, 1): κᵢ stops a landing node near f·d̂
        self_contact: bool = False,
        self_contact_distance: Optional[float] = None,
        self_contact_stiffness: Optional[float] = None,
        self_contact_friction: float = 0.0,
    ) -> "Simulation": ...
    def step(self) -> None: ...
    def run(
        self, steps: int, callback: Optional[Callable[["Simulation"], Optional[bool]]] = None
    ) -> Dict[str, npt.NDArray[Any]]: ...  # "step" int64, the others float64
    def run_adaptive(
        self,
        end_time: float,
        tolerance: float,
        *,
        output_interval: Optional[float] = None,
        min_dt: float = 0.0,
        max_dt: float = ...,
    ) -> Dict[str, Any]: ...  # "time", "dt" float64 arrays; estimates, counts, dt_min, dt_max
    def energy(self) -> Dict[str, float]: ...
    @property
    def newton_stats(self) -> Optional[Dict[str, int]]: ...
    @property
    def time(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @dt.setter
    def dt(self, value: float) -> None: ...
    @property
    def method(self) -> str: ...
    @property
    def model(self) -> str: ...
    @property
    def free_count(self) -> int: ...
    @property
    def displacement(self) -> _FloatArray: ...
    @displacement.setter
    def displacement(self, value: _ArrayLike) -> None: ...
    @property
    def velocity(self) -> _FloatArray: ...
    @velocity.setter
    def velocity(self, value: _ArrayLike) -> None: ...
    @property
    def critical_time_step(self) -> float: ...
    def von_mises(self) -> _FloatArray: ...
    def reactions(self) -> _FloatArray: ...
    def free_stiffness(self) -> _SparseMatrix: ...
    def free_mass(self) -> _SparseMatrix: ...
    @property
    def free_dofs(self) -> _IndexArray: ...
    def modes(self, count: int = 6) -> ModalResult: ...
    def checkpoint(self, path: _Path) -> None: ...
    def restore(self, path: _Path) -> None: ...

def solve_static(
    mesh: Mesh,
    material: _Materials,
    constraints: Constraints,
    loads: Loads,
    model: Union[_Model, Sequence[_Model]] = ...,  # "linear"; or one per material
    linear_solver: _LinearSolver = "auto",
    load_steps: int = 10,
    tolerance: Optional[float] = None,
    max_iterations: int = 30,
    obstacles: Optional[Sequence[Obstacle]] = None,
    contact_distance: Optional[float] = None,
    contact_stiffness: Optional[float] = None,
    self_contact: bool = False,
    self_contact_distance: Optional[float] = None,
    self_contact_stiffness: Optional[float] = None,
    self_contact_friction: float = 0.0,
) -> StaticResult: ...
def solve_static_mixed(
    mesh: Mesh,
    material: _Materials,
    constraints: Constraints,
    loads: Loads,
    model: _Model = "linear",
    load_steps: int = 10,
    max_iterations: int = 30,
) -> Dict[str, Any]: ...
def modal_analysis(
    mesh: Mesh, material: _Materials, constraints: Constraints, count: int = 6, mass: _Mass = "lumped"
) -> ModalResult: ...
def mixed_modal_analysis(
    mesh: Mesh, material: _Materials, constraints: Constraints, count: int = 6
) -> Dict[str, Any]: ...
def mixed_transient(
    mesh: Mesh,
    material: _Materials,
    constraints: Constraints,
    loads: Loads,
    dt: float,
    steps: int,
    method: _Method = "newmark",
    alpha: float = 0.0,
) -> Dict[str, Any]: ...
def mixed_neo_hookean_transient(
    mesh: Mesh,
    material: _Materials,
    constraints: Constraints,
    loads: Loads,
    dt: float,
    steps: int,
    *,
    model: Literal["neo_hookean", "neo-hookean", "corotational"] = "neo_hookean",
    initial_velocity: Optional[_ArrayLike] = None,
    obstacles: Optional[Sequence[Obstacle]] = None,
    contact_distance: Optional[float] = None,
    contact_stiffness: Optional[float] = None,
    tolerance: float = 1e-8,
) -> Dict[str, Any]: ...
def run_scene(path: _Path, output_dir: Optional[_Path] = None, write_files: bool = True) -> Dict[str, Any]: ...
def stiffness_matrix(mesh: Mesh, material: _Materials) -> _SparseMatrix: ...
def mass_matrix(mesh: Mesh, material: _Materials, mass: _Mass = "lumped") -> _SparseMatrix: ...
def estimate_error(mesh: Mesh, material: _Materials, displacement: _ArrayLike, model: str = ...) -> Dict[str, Any]: ...
def model_advice(mesh: Mesh, displacement: _ArrayLike) -> Dict[str, Any]: ...
