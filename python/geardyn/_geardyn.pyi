"""Type stubs of the extension module (python/src/lib.rs). Use the wrappers in
``geardyn/__init__.py``; these are the raw calls they make."""

import os
import pathlib
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class GeardynError(Exception):
    """A bad scene or option, or a failed solve; the message is the CLI's."""

class Scene:
    """A validated scene (single mesh or drivetrain) with its TOML text.

    ``scene[path]`` reads and ``scene[path] = value`` sets a parameter by its path in the
    file (``mesh.stiffness.mean``, ``gear[1].inertia``); every change re-validates the whole
    scene and raises GeardynError with the CLI's message, leaving the scene unchanged."""

    @staticmethod
    def from_file(path: Union[str, os.PathLike[str]]) -> Scene: ...
    @staticmethod
    def from_toml(text: str, origin: str = "<string>") -> Scene: ...
    @staticmethod
    def from_dict(data: Dict[str, Any], origin: str = "<dict>") -> Scene: ...
    @staticmethod
    def example(name: str) -> Scene: ...
    @staticmethod
    def examples() -> List[str]: ...
    def __getitem__(self, path: str) -> Any: ...
    def __setitem__(self, path: str, value: Any) -> None: ...
    def __contains__(self, path: str) -> bool: ...
    def update(self, values: Dict[str, Any]) -> None: ...
    def paths(self) -> List[str]: ...
    def describe(self, path: str) -> Parameter: ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def copy(self) -> Scene: ...
    @property
    def name(self) -> str: ...
    @property
    def mesh_frequencies(self) -> List[Tuple[str, float]]: ...
    @property
    def is_train(self) -> bool: ...
    @property
    def origin(self) -> str: ...
    @property
    def file(self) -> Optional[pathlib.Path]: ...

def simulate(
    scene: Scene,
    max_rows: Optional[int] = None,
    max_periods: Optional[float] = None,
    work_budget: Optional[float] = None,
    statistics: bool = True,
    timeout: Optional[float] = None,
) -> Tuple[
    List[str],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    str,
    Dict[str, int],
    Optional[List[Dict[str, Any]]],
    str,
]: ...
def periodic(
    scene: Scene,
    periods: int = 1,
    warmup: int = 20,
    speed: Optional[str] = None,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Dict[str, Any]: ...
def parse_speed(text: str) -> float: ...
def column_unit(name: str) -> Optional[str]: ...
def parameter_unit(path: str) -> Optional[str]: ...
def describe(path: str) -> Parameter: ...

class Parameter:
    """One parameter of the scene format (``Scene.describe``, ``geardyn.describe``)."""

    path: str
    value: Any
    default: Any
    is_default: bool
    kind: str
    unit: Optional[str]
    bounds: str
    minimum: Optional[Tuple[float, bool]]
    maximum: Optional[Tuple[float, bool]]
    choices: List[str]
    description: str
    required: bool
def sweep(
    scene: Scene,
    speed: str,
    direction: str = "both",
    tolerance: float = 1e-7,
    max_periods: int = 3000,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Tuple[List[str], npt.NDArray[np.float64]]: ...
def hb(
    scene: Scene,
    speed: str,
    harmonics: int = 20,
    subharmonic: int = 1,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Tuple[List[str], npt.NDArray[np.float64]]: ...
def modes(scene: Scene, rigid_bearings: bool = False) -> Dict[str, Any]: ...
def stiffness(
    gears: str, torque: float, etc: bool = True, harmonics: int = 4
) -> Tuple[List[str], npt.NDArray[np.float64], str]: ...
def build_fmu(scene: str, out: str, cdylib: str) -> pathlib.Path: ...
def run(
    fmu: str,
    out: str,
    start_time: Optional[float] = None,
    stop_time: Optional[float] = None,
    output_interval: Optional[float] = None,
    max_rows: Optional[int] = None,
    start: List[str] = ...,
    input: Optional[str] = None,
    outputs: Optional[List[str]] = None,
    log_level: str = "warning",
    algorithm: Optional[str] = None,
    extrapolation: Optional[str] = None,
    threads: Optional[int] = None,
    divergence_factor: Optional[float] = None,
    tolerance: Optional[float] = None,
    min_step: Optional[float] = None,
    max_step: Optional[float] = None,
) -> int: ...
def _pythonic(message: str) -> str: ...
def spectrum(
    scene: Scene,
    out: str,
    signals: List[str],
    samples: int,
    periods: int,
    work_budget: Optional[float] = None,
    plot: Optional[str] = None,
) -> str: ...
def waterfall(
    scene: Scene,
    out: str,
    mesh: Optional[str] = None,
    signal: str = "dte",
    segment: Optional[int] = None,
    overlap: float = 0.5,
    window: str = "hann",
    order_cuts: Optional[str] = None,
    mesh_orders: Optional[List[float]] = None,
    shaft_orders: Optional[List[float]] = None,
    revolutions: Optional[int] = None,
    order_samples: Optional[int] = None,
    work_budget: Optional[float] = None,
    plot: Optional[str] = None,
    order_plot: Optional[str] = None,
) -> str: ...
def floquet(scene: Scene, speed: Optional[str] = None, mu: Optional[float] = None) -> str: ...
def band(scene: Scene, speed: str, points: int, mu: Optional[float] = None) -> str: ...
