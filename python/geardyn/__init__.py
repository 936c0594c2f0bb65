"""geardyn: gear-mesh drivetrain dynamics from Python.

The solves run in the Rust library (``geardyn._geardyn``, built with PyO3), through the same
functions as the ``geardyn`` CLI, so a Python call and a CLI run of the same scene give
bit-identical numbers and the same error messages. The GIL is released during every solve:
threads run in parallel.

>>> import geardyn
>>> scene = geardyn.Scene.example("spur_pair")
>>> scene["mesh.stiffness.mean"] = 2.5e8          # validated like the scene file
>>> run = geardyn.simulate(scene)
>>> run["mesh.dte"].std(), run.units["mesh.dte"]

Scene parameters are addressed by their path in the TOML file (``mesh.stiffness.mean``,
``gear[1].inertia``); the CLI's solver options (``--stop-time``, ``--rtol``, …) are the
scene's ``solver.*`` parameters here, so there is one way to set each of them. Speeds take
the CLI's spellings (``"4500rpm"``, ``"471.24rad/s"``; a number is rad/s). Parameter studies on Dask: :mod:`geardyn.study`.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Union

import numpy as np

from ._geardyn import GeardynError, Scene, __version__
from . import _geardyn

__all__ = [
    "GeardynError",
    "Scene",
    "Simulation",
    "Table",
    "Orbit",
    "Modes",
    "Stiffness",
    "simulate",
    "periodic",
    "sweep",
    "hb",
    "modes",
    "stiffness",
    "build_fmu",
    "unit",
    "parse_speed",
    "__version__",
]


def unit(name: str) -> Optional[str]:
    """Unit of an output column (simulation, sweep, hb, stiffness), or None when the name is
    not a known output: the table the CLI's ``--units`` headers use (``docs/units.md``)."""
    return _geardyn.column_unit(name)


def parse_speed(speed: Union[str, float]) -> float:
    """A speed in rad/s from ``"4500rpm"``, ``"471.24rad/s"`` or a number (rad/s), as the
    CLI's ``--speed`` reads it."""
    return _geardyn.parse_speed(_speed_text(speed))


def _speed_text(speed: Union[str, float]) -> str:
    # `repr` of a float round-trips, so a number reaches the parser exactly.
    return speed if isinstance(speed, str) else repr(float(speed))


@dataclass
class Simulation:
    """A sampled run: ``time`` (s) and one column per output (``names``, SI ``units``), and
    each mesh's statistics over the run (``statistics``: ``geardyn simulate``'s summary)."""

    names: List[str]
    time: np.ndarray
    data: np.ndarray  # shape (len(time), len(names))
    method: str
    stats: Dict[str, int]
    scene_name: str
    # One dict per mesh, the numbers `geardyn simulate` prints, bit for bit: `name`,
    # `prefix`, `mesh_frequency` (Hz), the per-mesh columns of `sweep` (dte_mean, dte_rms,
    # dte_peak_to_peak, a1-a3, contact_loss_fraction, separation_phase, peak_force,
    # force_rms, dynamic_factor) and `pair_contact_loss_fractions` (one per tooth-pair slot
    # of a Model-1 mesh). From the continuous solution (`statistics_source` "exact segments"
    # or, on the RK path, "dense output": event times, integrals over each smooth piece,
    # refined extremes); with speed or torque profiles only `dte_rms`, `peak_force` and
    # `contact_loss_fraction`, of the output rows ("output samples"). None when
    # `simulate(..., statistics=False)`.
    statistics: Optional[List[Dict[str, Union[str, float, List[float]]]]] = None
    statistics_source: str = "output samples"
    units: Dict[str, Optional[str]] = field(init=False)

    def __post_init__(self) -> None:
        self.units = {n: unit(n) for n in ["time", *self.names]}

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.time
        try:
            return self.data[:, self.names.index(name)]
        except ValueError:
            raise KeyError(f"no output '{name}' (outputs: {', '.join(self.names)})") from None

    def to_pandas(self):
        """A DataFrame indexed by time; units in ``df.attrs["units"]`` (needs pandas)."""
        import pandas as pd

        df = pd.DataFrame(self.data, columns=self.names, index=pd.Index(self.time, name="time"))
        df.attrs["units"] = dict(self.units)
        df.attrs["scene"] = self.scene_name
        df.attrs["method"] = self.method
        return df

    def to_xarray(self):
        """An xarray Dataset over ``time``; each variable's unit in ``.attrs["units"]``."""
        import xarray as xr

        ds = xr.Dataset(
            {n: ("time", self.data[:, i], {"units": self.units[n]}) for i, n in enumerate(self.names)},
            coords={"time": ("time", self.time, {"units": "s"})},
            attrs={"scene": self.scene_name, "method": self.method},
        )
        return ds


@dataclass
class Table:
    """A result table (the CSV the CLI writes): ``columns`` and one ``data`` row per point."""

    columns: List[str]
    data: np.ndarray
    units: Dict[str, Optional[str]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.units = {c: unit(c) for c in self.columns}

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.data[:, self.columns.index(name)]
        except ValueError:
            raise KeyError(f"no column '{name}' (columns: {', '.join(self.columns)})") from None

    def __len__(self) -> int:
        return self.data.shape[0]

    def to_pandas(self):
        import pandas as pd

        return pd.DataFrame(self.data, columns=self.columns)


@dataclass
class Orbit:
    """A periodic orbit found by shooting (``geardyn periodic``)."""

    period: float
    periods: int
    y0: np.ndarray
    multipliers: np.ndarray
    spectral_radius: float
    stability: str
    residuals: np.ndarray
    monodromy: np.ndarray
    report: str
    speed: float  # input speed, rad/s
    speed_rpm: float
    # Per mesh: prefix, mesh_frequency (Hz) and the per-mesh columns of sweep and hb
    # (dte_mean, dte_rms, dte_peak_to_peak, a1-a3, contact_loss_fraction, separation_phase,
    # peak_force, force_rms, dynamic_factor), and pair_contact_loss_fractions (one per
    # tooth-pair slot of a Model-1 mesh, from the event times; empty otherwise).
    meshes: List[Dict[str, Union[str, float]]]


@dataclass
class Modes:
    """Natural frequencies (Hz) and mode shapes (rows, over ``labels``) of the mean system."""

    labels: List[str]
    frequencies: np.ndarray
    rigid: np.ndarray
    shapes: np.ndarray
    report: str


@dataclass
class Stiffness(Table):
    """A mesh-stiffness curve over one mesh period (``geardyn stiffness``), with its summary."""

    summary: str = ""


def simulate(
    scene: Scene,
    max_rows: Optional[int] = None,
    max_periods: Optional[float] = None,
    work_budget: Optional[float] = None,
    statistics: bool = True,
) -> Simulation:
    """Simulates ``scene`` from t = 0 to ``solver.stop_time``, sampled every
    ``solver.output_interval`` (what ``geardyn simulate`` writes to CSV), with each mesh's
    statistics over the run from the continuous solution (``Simulation.statistics``, the
    summary ``geardyn simulate`` prints, bit for bit; ``statistics=False`` skips them, as
    ``--quiet`` does, and the run costs about half).

    The run limits of ``geardyn simulate`` apply (``--max-rows``, ``--max-periods``,
    ``--work-budget``: output rows, mesh and mode periods, and the work budget in work units,
    the scene's ``solver.work_budget``); pass ``max_rows``, ``max_periods`` or ``work_budget``
    to change them. A run beyond its work budget
    stops with a :class:`GeardynError` that names the likely cause (stiffness, speed, step
    count). The rows are held in memory, so a result of more than 2e8 values is refused:
    stream it to a CSV file with ``geardyn simulate`` instead."""
    names, time, data, method, stats, per_mesh, source = _geardyn.simulate(
        scene, max_rows, max_periods, work_budget, statistics
    )
    return Simulation(names, time, data, method, stats, scene.name, per_mesh, source)


def periodic(
    scene: Scene,
    periods: int = 1,
    warmup: int = 20,
    speed: Union[str, float, None] = None,
    work_budget: Optional[float] = None,
) -> Orbit:
    """Periodic steady state of any scene at its input speed (``operating.pinion_speed`` or
    ``operating.input_speed``, or ``speed``: ``"4500rpm"``, ``"471.24rad/s"`` or a number in
    rad/s) by Newton shooting, with Floquet multipliers and stability: a period-``periods``
    orbit after ``warmup`` response periods (the least common multiple of the mesh periods),
    and each mesh's peak and RMS force and dynamic factor (``meshes``). ``work_budget`` is the
    work budget of each run, as in :func:`sweep`."""
    text = None if speed is None else _speed_text(speed)
    raw = _geardyn.periodic(scene, periods, warmup, text, work_budget)
    raw["multipliers"] = np.array([complex(re, im) for re, im in raw["multipliers"]])
    return Orbit(**raw)


def sweep(
    scene: Scene,
    speed: str,
    direction: str = "both",
    tolerance: float = 1e-7,
    max_periods: int = 3000,
    work_budget: Optional[float] = None,
) -> Table:
    """Frequency-response sweep of any scene over input-gear speeds
    ``speed = "from:to:points"`` (``"1000rpm:10000rpm:181"``, ``"300rad/s:700rad/s:41"``; bare
    numbers are rad/s), ``direction`` up | down | both; the table of
    ``geardyn sweep`` (per-mesh columns prefixed ``<mesh>_`` in a drivetrain).

    ``work_budget`` (work units, the scene's ``solver.work_budget``, the CLI's
    ``--work-budget``) bounds each run of the analysis (each sweep point); unset, the scene's
    or the default run budget applies. A run beyond it raises :class:`GeardynError` naming
    the likely cause; a value that is not a finite number >= 1 raises ``ValueError``."""
    return Table(*_geardyn.sweep(scene, speed, direction, tolerance, max_periods, work_budget))


def hb(
    scene: Scene,
    speed: str,
    harmonics: int = 20,
    subharmonic: int = 1,
    work_budget: Optional[float] = None,
) -> Table:
    """Harmonic balance with arclength continuation over ``speed = "from:to"``
    (``"3000rpm:6000rpm"``; bare numbers are rad/s); the
    table of ``geardyn hb``. ``work_budget`` as in :func:`sweep`."""
    return Table(*_geardyn.hb(scene, speed, harmonics, subharmonic, work_budget))


def modes(scene: Scene, rigid_bearings: bool = False) -> Modes:
    """Natural frequencies and mode shapes of any scene's mean system (``geardyn modes``; a
    single pair as its one-mesh drivetrain)."""
    raw = _geardyn.modes(scene, rigid_bearings)
    raw["rigid"] = np.array(raw["rigid"], dtype=bool)
    return Modes(**raw)


def stiffness(
    gears: Union[str, os.PathLike], torque: float, etc: bool = True, harmonics: int = 4
) -> Stiffness:
    """Mesh stiffness over one mesh period from a gears file (``geardyn stiffness``) at
    pinion torque ``torque`` (N·m), with extended tooth contact if ``etc``."""
    columns, data, summary = _geardyn.stiffness(os.fspath(gears), torque, etc, harmonics)
    return Stiffness(columns, data, summary)


def _default_cdylib() -> Path:
    """The FMU binary: ``$GEARDYN_CDYLIB``, else the source tree's ``target/release`` (the
    module is installed from the source tree by scripts/setup-python.sh)."""
    env = os.environ.get("GEARDYN_CDYLIB")
    if env:
        return Path(env)
    lib = Path(__file__).resolve().parents[2] / "target" / "release" / "libgeardyn.so"
    if not lib.is_file():
        raise GeardynError(
            f"libgeardyn.so not found at {lib} (build it with `cargo build --release`, "
            "or pass cdylib= or set GEARDYN_CDYLIB)"
        )
    return lib


def build_fmu(
    scene: Union[Scene, str, os.PathLike],
    out: Union[str, os.PathLike],
    cdylib: Union[str, os.PathLike, None] = None,
) -> Path:
    """Builds ``<out>/<modelIdentifier>.fmu`` (``geardyn fmu build``) and returns its path.

    ``scene`` is a scene file or folder, or a :class:`Scene`: one read from a file and left
    unchanged ships that file (and the folder's README); a changed one ships its TOML text."""
    lib = Path(cdylib) if cdylib is not None else _default_cdylib()
    if isinstance(scene, Scene):
        if scene.file is not None:
            return Path(_geardyn.build_fmu(os.fspath(scene.file), os.fspath(out), os.fspath(lib)))
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "scene.toml"
            path.write_text(scene.to_toml())
            return Path(_geardyn.build_fmu(os.fspath(path), os.fspath(out), os.fspath(lib)))
    return Path(_geardyn.build_fmu(os.fspath(scene), os.fspath(out), os.fspath(lib)))
