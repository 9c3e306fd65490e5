"""Type stubs of the extension module distlab._core (the public API is in distlab.gap,
distlab.kelvin and distlab.cbf, which wrap it)."""

from typing import Any, Callable, Dict, Optional, Tuple

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
def kelvin_solve(request: Dict[str, Any], progress: Optional[Callable[[str, float], Any]] = None) -> Dict[str, Any]: ...
def cbf_rollout(
    request: Dict[str, Any], progress: Optional[Callable[[int, float], Any]] = None, every: int = 1
) -> Dict[str, Any]: ...
def cbf_sweep(request: Dict[str, Any], progress: Optional[Callable[[str, float], Any]] = None) -> Dict[str, Any]: ...

class KelvinField:
    @staticmethod
    def prepare(
        vertices: Optional[npt.NDArray[np.float64]],
        faces: Optional[np.ndarray],
        path: Optional[str],
        options: Dict[str, Any],
        cache_dir: Optional[str],
        progress: Optional[Callable[[str, float], Any]],
    ) -> "KelvinField": ...
    def set_sigma(self, sigma: Dict[str, Any], gradients: bool = True) -> None: ...
    def build_boundary_response(
        self, max_megabytes: Any, progress: Optional[Callable[[str, float], Any]] = None
    ) -> bool: ...
    def query(
        self, points: npt.NDArray[np.float64], hints: bool = True
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int8]]: ...
    def isosurface(self, level: float) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def export(self, path: str, level: float, format: str) -> None: ...
    def stats(self) -> Dict[str, Any]: ...
    def surface(self) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def centre(self) -> npt.NDArray[np.float64]: ...
