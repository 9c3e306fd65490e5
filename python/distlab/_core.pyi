"""Type stubs of the extension module distlab._core (the public API is in distlab.gap,
distlab.kelvin, distlab.cbf and distlab.robot, which wrap it)."""

from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

def gap_solve(request: Dict[str, Any]) -> Dict[str, Any]: ...
def gap_batch(
    shape_a: Dict[str, Any],
    poses_a: npt.NDArray[np.float64],
    shape_b: Dict[str, Any],
    poses_b: npt.NDArray[np.float64],
    params: Optional[Dict[str, Any]],
    threads: int,
    warm_a: Optional[npt.NDArray[np.float64]],
    warm_b: Optional[npt.NDArray[np.float64]],
    euclidean: bool = True,
    progress: Optional[Callable[[int, int], Any]] = None,
    track: Optional[npt.NDArray[np.float64]] = None,
) -> Dict[str, Optional[np.ndarray]]: ...
def gap_default_params() -> Dict[str, Any]: ...
def kelvin_solve(
    request: Dict[str, Any], progress: Optional[Callable[[str, float], Any]] = None, mesh_worker: str = ""
) -> Dict[str, Any]: ...
def cache_default_dir() -> str: ...
def cache_ls(dir: str) -> Dict[str, Any]: ...
def cache_verify(dir: str, fix: bool) -> Dict[str, Any]: ...
def cache_gc(dir: str, budget: Optional[int], keep_recent: float) -> Dict[str, Any]: ...
def cbf_rollout(
    request: Dict[str, Any], progress: Optional[Callable[[int, float], Any]] = None, every: int = 1
) -> Dict[str, Any]: ...
def cbf_sweep(request: Dict[str, Any], progress: Optional[Callable[[str, float], Any]] = None) -> Dict[str, Any]: ...

class KelvinStageProgress:
    def __init__(self, grading: float = ..., vertices: float = ..., response: bool = ...) -> None: ...
    def report(self, stage: str, fraction: float) -> float: ...

class KelvinField:
    @staticmethod
    def prepare(
        vertices: Optional[npt.NDArray[np.float64]],
        faces: Optional[np.ndarray],
        path: Optional[str],
        options: Dict[str, Any],
        cache_dir: Optional[str],
        progress: Optional[Callable[[str, float], Any]],
        mesh_worker: str = "",
    ) -> "KelvinField": ...
    def set_sigma(self, sigma: Dict[str, Any], gradients: bool = True) -> None: ...
    def build_boundary_response(
        self, max_megabytes: Any, progress: Optional[Callable[[str, float], Any]] = None
    ) -> bool: ...
    def query(
        self, points: npt.NDArray[np.float64], hints: bool = True
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int8]]: ...
    def isosurface(self, level: float) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def export(self, path: str, level: float, format: str) -> Dict[str, Any]: ...
    def stats(self) -> Dict[str, Any]: ...
    def surface(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def centre(self) -> npt.NDArray[np.float64]: ...

class RobotState:
    """The GAP tracks a robot batch ended with (warm_start of the next call), tied to its model."""

    metric: str
    def pairs(self) -> List[Dict[str, Any]]: ...

class Robot:
    @staticmethod
    def from_file(
        path: str, package_dirs: Dict[str, str], package_search_dirs: List[str], require_closed_meshes: bool
    ) -> "Robot": ...
    @staticmethod
    def load(name: str) -> "Robot": ...
    name: str
    dof: int
    joint_names: List[str]
    joint_types: List[str]
    links: List[str]
    ee_link: str
    q_min: npt.NDArray[np.float64]
    q_max: npt.NDArray[np.float64]
    velocity_max: npt.NDArray[np.float64]
    collision_elements: List[Dict[str, Any]]
    warnings: List[str]
    def fk(self, q: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def jacobian(
        self, q: npt.NDArray[np.float64], link: Optional[str] = None, point: Optional[npt.NDArray[np.float64]] = None
    ) -> npt.NDArray[np.float64]: ...
    def distances(
        self,
        q: npt.NDArray[np.float64],
        obstacles: List[Dict[str, Any]],
        metric: str,
        pairs: Any,
        params: Optional[Dict[str, Any]],
        threads: int,
        warm_start: Optional[RobotState],
        tracking: bool,
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, RobotState]: ...
    def cbf_rows(
        self,
        q: npt.NDArray[np.float64],
        obstacles: List[Dict[str, Any]],
        metric: str,
        pairs: Any,
        margins: Optional[Dict[str, float]],
        eta: float,
        eta_joint: float,
        params: Optional[Dict[str, Any]],
        threads: int,
        warm_start: Optional[RobotState],
        tracking: bool,
        fields: Optional[FieldBarrier],
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], Tuple[Any, ...]]: ...

class FieldBarrier:
    """Kelvin fields as barriers on a robot's control points (cbf/fields.hpp), prepared once."""

    names: List[str]
    margins: List[float]
    points: List[Dict[str, Any]]
    def __init__(
        self, robot: Robot, fields: List[Dict[str, Any]], control_points: List[Dict[str, Any]], cache_dir: Optional[str]
    ) -> None: ...
    def evaluate(
        self, q: npt.NDArray[np.float64], gradient: str
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...

def cbf_controller_rows(
    request: Dict[str, Any], q: npt.NDArray[np.float64]
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], List[str]]: ...
