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
from typing import Dict, List, Optional, Sequence, Union

import numpy as np

from ._geardyn import GeardynError, Parameter, Scene, __version__
from . import _geardyn

__all__ = [
    "GeardynError",
    "Parameter",
    "Scene",
    "describe",
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
    "spectrum",
    "waterfall",
    "floquet",
    "band",
    "Spectrum",
    "Waterfall",
    "build_fmu",
    "run",
    "FmuRun",
    "unit",
    "parse_speed",
    "__version__",
]


def describe(path: str) -> Parameter:
    """What the scene format says about a parameter path, without a scene: default, unit,
    bounds (those validation applies), choices and description (``Scene.describe`` adds a
    scene's own value). ``geardyn.describe("solver.atol").default`` is ``1e-15``."""
    return _geardyn.describe(path)


def unit(name: str) -> Optional[str]:
    """Unit of a scene parameter by its path (``"operating.pinion_speed"`` → ``"rad/s"``,
    ``"gear[0].inertia"`` → ``"kg.m^2"``) or of an output column (simulation, sweep, hb,
    stiffness: the table the CLI's ``--units`` headers use), or None when the name is neither
    a numeric parameter nor a known output (``docs/units.md``). The strings are UDUNITS and
    pint units both (``pint.UnitRegistry().Unit(geardyn.unit(name))``)."""
    return _geardyn.parameter_unit(name) or _geardyn.column_unit(name)


def parse_speed(speed: Union[str, float]) -> float:
    """A speed in rad/s from ``"4500rpm"``, ``"471.24rad/s"`` or a number (rad/s), as the
    CLI's ``--speed`` reads it."""
    return _geardyn.parse_speed(_speed_text(speed))


def _speed_text(speed: Union[str, float]) -> str:
    # `repr` of a float round-trips, so a number reaches the parser exactly.
    return speed if isinstance(speed, str) else repr(float(speed))


class _TimeRows:
    """Rows over ``time`` (s) with one column per name in ``names`` and each column's unit in
    ``units``: what :class:`Simulation` and :class:`FmuRun` share. ``_attrs()`` gives the
    attributes of the frame or dataset."""

    names: List[str]
    time: np.ndarray
    data: np.ndarray
    units: Dict[str, Optional[str]]

    def _attrs(self) -> Dict[str, str]:
        return {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "time":
            return self.time
        try:
            return self.data[:, self.names.index(name)]
        except ValueError:
            raise KeyError(f"no column '{name}' (columns: {', '.join(self.names)})") from None

    def to_pandas(self):
        """A DataFrame indexed by time; units in ``df.attrs["units"]`` (needs pandas)."""
        import pandas as pd

        df = pd.DataFrame(self.data, columns=self.names, index=pd.Index(self.time, name="time"))
        df.attrs["units"] = dict(self.units)
        df.attrs.update(self._attrs())
        return df

    def plot(self, signals: Optional[Sequence[str]] = None, ax=None):
        """A matplotlib Figure of ``signals`` over time (default: the DTE columns), one axes
        per unit, labelled with units (:func:`geardyn.plotting.simulation`)."""
        from . import plotting

        return plotting.simulation(self, signals, ax)

    def to_xarray(self):
        """An xarray Dataset over ``time``; each variable's unit in ``.attrs["units"]``."""
        import xarray as xr

        return xr.Dataset(
            {n: ("time", self.data[:, i], {"units": self.units[n]}) for i, n in enumerate(self.names)},
            coords={"time": ("time", self.time, {"units": "s"})},
            attrs=self._attrs(),
        )


@dataclass
class Simulation(_TimeRows):
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
        self.units = {n: _geardyn.column_unit(n) for n in ["time", *self.names]}

    def _attrs(self) -> Dict[str, str]:
        return {"scene": self.scene_name, "method": self.method}


@dataclass
class Table:
    """A result table (the CSV the CLI writes): ``columns`` and one ``data`` row per point."""

    columns: List[str]
    data: np.ndarray
    units: Dict[str, Optional[str]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.units = {c: _geardyn.column_unit(c) for c in self.columns}

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.data[:, self.columns.index(name)]
        except ValueError:
            raise KeyError(f"no column '{name}' (columns: {', '.join(self.columns)})") from None

    def __len__(self) -> int:
        return self.data.shape[0]

    def to_pandas(self):
        """A DataFrame of the rows; units in ``df.attrs["units"]`` (needs pandas)."""
        import pandas as pd

        df = pd.DataFrame(self.data, columns=self.columns)
        df.attrs["units"] = dict(self.units)
        return df

    # Columns that label a row rather than measure it: coordinates of the Dataset.
    _COORDINATES = ("speed", "speed_rpm", "direction", "frequency_Hz", "time_s", "rpm", "order",
                    "phase", "block", "revolutions")

    def plot(self, y: Union[str, Sequence[str]] = "dte_rms", x: str = "speed", ax=None):
        """A matplotlib Figure of columns ``y`` against ``x``, labelled with units; a sweep's
        directions and an hb branch's unstable points apart (:func:`geardyn.plotting.table`)."""
        from . import plotting

        return plotting.table(self, y, x, ax)

    def to_xarray(self, dim: str = "point"):
        """An xarray Dataset along ``dim`` (one entry per row): the speed, direction or
        frequency columns as coordinates, every other column a variable, each with its unit
        in ``attrs["units"]`` (needs xarray)."""
        import xarray as xr

        def attrs(c):
            return {"units": self.units[c]} if self.units.get(c) else {}

        coords = {c: (dim, self[c], attrs(c)) for c in self.columns if c in self._COORDINATES}
        data = {c: (dim, self[c], attrs(c)) for c in self.columns if c not in self._COORDINATES}
        return xr.Dataset(data, coords=coords)


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
    timeout: Optional[float] = None,
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
    stream it to a CSV file with ``geardyn simulate`` instead.

    ``timeout`` (seconds of wall-clock time) stops a solve still running then with a
    :class:`GeardynError` that says so (a study's per-point timeout). Unlike the work budget it
    depends on the machine; a run that ends in time is bit-identical to one without it."""
    names, time, data, method, stats, per_mesh, source = _geardyn.simulate(
        scene, max_rows, max_periods, work_budget, statistics, timeout
    )
    return Simulation(names, time, data, method, stats, scene.name, per_mesh, source)


def periodic(
    scene: Scene,
    periods: int = 1,
    warmup: int = 20,
    speed: Union[str, float, None] = None,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Orbit:
    """Periodic steady state of any scene at its input speed (``operating.pinion_speed`` or
    ``operating.input_speed``, or ``speed``: ``"4500rpm"``, ``"471.24rad/s"`` or a number in
    rad/s) by Newton shooting, with Floquet multipliers and stability: a period-``periods``
    orbit after ``warmup`` response periods (the least common multiple of the mesh periods),
    and each mesh's peak and RMS force and dynamic factor (``meshes``). ``work_budget`` is the
    work budget of each run, as in :func:`sweep`; ``timeout`` as in :func:`simulate`."""
    text = None if speed is None else _speed_text(speed)
    raw = _geardyn.periodic(scene, periods, warmup, text, work_budget, timeout)
    raw["multipliers"] = np.array([complex(re, im) for re, im in raw["multipliers"]])
    return Orbit(**raw)


def sweep(
    scene: Scene,
    speed: str,
    direction: str = "both",
    tolerance: float = 1e-7,
    max_periods: int = 3000,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Table:
    """Frequency-response sweep of any scene over input-gear speeds
    ``speed = "from:to:points"`` (``"1000rpm:10000rpm:181"``, ``"300rad/s:700rad/s:41"``; bare
    numbers are rad/s), ``direction`` up | down | both; the table of
    ``geardyn sweep`` (per-mesh columns prefixed ``<mesh>_`` in a drivetrain).

    ``work_budget`` (work units, the scene's ``solver.work_budget``, the CLI's
    ``--work-budget``) bounds each run of the analysis (each sweep point); unset, the scene's
    or the default run budget applies. A run beyond it raises :class:`GeardynError` naming
    the likely cause; a value that is not a finite number >= 1 raises ``ValueError``.
    ``timeout`` (seconds) bounds the whole sweep, as in :func:`simulate`."""
    return Table(*_geardyn.sweep(scene, speed, direction, tolerance, max_periods, work_budget,
                                 timeout))


def hb(
    scene: Scene,
    speed: str,
    harmonics: int = 20,
    subharmonic: int = 1,
    work_budget: Optional[float] = None,
    timeout: Optional[float] = None,
) -> Table:
    """Harmonic balance with arclength continuation over ``speed = "from:to"``
    (``"3000rpm:6000rpm"``; bare numbers are rad/s); the
    table of ``geardyn hb``. ``work_budget`` and ``timeout`` as in :func:`sweep`. What the
    CLI's summary says the table cannot be trusted for (a branch that ends short of the
    interval because the harmonics do not resolve the orbit there, verdicts or statistics
    that may be wrong) is raised as a ``RuntimeWarning``."""
    return Table(*_geardyn.hb(scene, speed, harmonics, subharmonic, work_budget, timeout))


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


def _read_table(path: Path) -> "tuple[List[str], np.ndarray, Dict[str, List[str]]]":
    """A CSV the CLI wrote: numeric columns as exact doubles (the CLI writes shortest
    round-trip floats), flags (``True``/``False``) as 1.0/0.0, text columns (order labels)
    apart."""
    import csv

    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    numeric, text = [], {}
    for j, name in enumerate(header):
        values = [r[j] for r in body]
        try:
            numeric.append((name, [float(v) for v in values]))
        except ValueError:
            if values and all(v in ("True", "False") for v in values):
                numeric.append((name, [1.0 if v == "True" else 0.0 for v in values]))
            else:
                text[name] = values
    columns = [n for n, _ in numeric]
    data = np.array([v for _, v in numeric], dtype=float).T.reshape(len(body), len(columns))
    return columns, data, text


@dataclass
class Spectrum(Table):
    """The exact spectrum of a periodic steady state (``geardyn spectrum``): one row per line,
    ``frequency_Hz`` and per signal ``<signal>_amplitude_<unit>``, ``<signal>_phase_rad``;
    ``labels`` names each line's order (``1×mesh``, ``DC``); ``report`` is the CLI's text."""

    labels: List[str] = field(default_factory=list)
    report: str = ""

    def __post_init__(self) -> None:
        # The CSV's column names carry their units: <signal>_amplitude_<unit>, _phase_rad.
        self.units = {}
        for c in self.columns:
            if c == "frequency_Hz":
                self.units[c] = "Hz"
            elif "_amplitude_" in c:
                self.units[c] = c.rsplit("_amplitude_", 1)[1]
            elif c.endswith("_phase_rad"):
                self.units[c] = "rad"
            else:
                self.units[c] = _geardyn.column_unit(c)

    def plot(self, signal: Optional[str] = None, lines: int = 8, ax=None):
        """A matplotlib Figure: a stem plot of one signal's amplitudes, the largest lines
        labelled with their orders (:func:`geardyn.plotting.spectrum`)."""
        from . import plotting

        return plotting.spectrum(self, signal, lines, ax)

    def to_xarray(self, dim: str = "line"):
        """The lines as a Dataset along ``line``, with ``frequency_Hz`` and each line's order
        ``label`` as coordinates and units on every variable."""
        ds = super().to_xarray(dim)
        return ds.assign_coords(label=(dim, list(self.labels)))


@dataclass
class Waterfall:
    """A run-up's order map (``geardyn waterfall``): ``map`` in long form (time_s, rpm,
    frequency_Hz, order, amplitude) and, when asked, ``order_cuts`` (one row per block:
    time_s, revolutions, speed, the amplitude and phase of each tracked order)."""

    map: Table
    order_cuts: Optional[Table]
    report: str


def _in_temporary(run, *names):
    """Runs ``run(paths...)`` with fresh file paths in a temporary folder, returning what it
    returns and the tables read from the paths it wrote."""
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(tmp) / n for n in names]
        result = run(*paths)
        tables = [_read_table(p) if p.exists() else None for p in paths]
    return result, tables


def spectrum(
    scene: Scene,
    signals: Optional[List[str]] = None,
    samples: int = 64,
    periods: int = 1,
    work_budget: Optional[float] = None,
    plot: Union[str, os.PathLike, None] = None,
) -> Spectrum:
    """The exact spectrum of any scene's periodic steady state (``geardyn spectrum``): the
    Fourier series of the shot orbit integrated over each segment, so the lines do not alias
    and do not depend on ``samples``, which sets only how far the spectrum reaches (half of it,
    in mesh orders). ``signals`` are output columns (default: every mesh's DTE); ``periods``
    response periods give the resolution 1/(periods·T); ``plot`` also draws it (PNG or SVG).
    The CLI's numbers, bit for bit."""
    plot_path = None if plot is None else os.fspath(plot)
    report, (table,) = _in_temporary(
        lambda out: _geardyn.spectrum(scene, os.fspath(out), list(signals or []), samples, periods,
                                      work_budget, plot_path),
        "spectrum.csv",
    )
    columns, data, text = table
    return Spectrum(columns, data, labels=text.get("order", []), report=report)


def waterfall(
    scene: Scene,
    mesh: Optional[str] = None,
    signal: str = "dte",
    segment: int = 1000,
    overlap: float = 0.5,
    window: str = "hann",
    order_cuts: bool = False,
    mesh_orders: Optional[List[float]] = None,
    shaft_orders: Optional[List[float]] = None,
    revolutions: int = 8,
    order_samples: int = 64,
    work_budget: Optional[float] = None,
    plot: Union[str, os.PathLike, None] = None,
    order_plot: Union[str, os.PathLike, None] = None,
) -> Waterfall:
    """The order map of a run-up scene (``geardyn waterfall``): short-time spectra of
    ``signal`` (dte or force) of ``mesh`` over the run, ``segment`` samples per window; with
    ``order_cuts`` the orders ``mesh_orders`` (of the mesh) and ``shaft_orders`` (of the input
    shaft) tracked in the angle domain over blocks of ``revolutions``. ``plot`` and
    ``order_plot`` also draw them. The CLI's numbers, bit for bit."""
    fspath = lambda p: None if p is None else os.fspath(p)  # noqa: E731

    def run(out, cuts):
        return _geardyn.waterfall(
            scene, os.fspath(out), mesh, signal, segment, overlap, window,
            os.fspath(cuts) if order_cuts else None, mesh_orders, shaft_orders, revolutions,
            order_samples, work_budget, fspath(plot), fspath(order_plot))

    report, (table, cuts) = _in_temporary(run, "waterfall.csv", "order_cuts.csv")
    columns, data, _ = table
    cut_table = None if cuts is None else Table(cuts[0], cuts[1])
    return Waterfall(Table(columns, data), cut_table, report)


def floquet(scene: Scene, speed: Union[str, float, None] = None, mu: Optional[float] = None) -> dict:
    """The monodromy of a linear scene over one period at its input speed or ``speed``
    (``geardyn floquet --json``): a dict with the monodromy, the multipliers, the load
    response and the stiffness segments. ``mu`` sets a helical pair's friction coefficient."""
    import json

    text = None if speed is None else _speed_text(speed)
    return json.loads(_geardyn.floquet(scene, text, mu))


def band(scene: Scene, speed: str, points: int = 400, mu: Optional[float] = None) -> str:
    """The parametric instability bands of a linear scene over input speeds ``speed =
    "from:to"`` (``geardyn band``), scanned at ``points`` speeds and their edges bisected; the
    CLI's report."""
    return _geardyn.band(scene, speed, points, mu)


def _default_cdylib() -> Path:
    """The FMU binary: ``$GEARDYN_CDYLIB``; else, in the source tree (the editable install of
    scripts/setup-python.sh), its ``target/release/libgeardyn.so``; else the copy an installed
    wheel carries beside this module (scripts/build-wheel.sh)."""
    env = os.environ.get("GEARDYN_CDYLIB")
    if env:
        return Path(env)
    here = Path(__file__).resolve().parent
    if (here.parents[1] / "Cargo.toml").is_file():
        lib = here.parents[1] / "target" / "release" / "libgeardyn.so"
        how = "build it with `cargo build --release`"
    else:
        lib = here / "libgeardyn.so"
        how = "the wheel was built without it: use scripts/build-wheel.sh"
    if not lib.is_file():
        raise GeardynError(
            f"libgeardyn.so not found at {lib} ({how}, or pass cdylib= or set GEARDYN_CDYLIB)"
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


@dataclass
class FmuRun(_TimeRows):
    """A run of an FMU or a system of FMUs (``geardyn run``): ``time`` (s) and one column per
    recorded variable (``names``; in a system ``Element.connector``), ``notes`` the lines the
    run printed (FMU log messages at ``log_level``, the master's notes), and the step sequence
    of an error-controlled system run (``steps``, else None)."""

    names: List[str]
    time: np.ndarray
    data: np.ndarray  # shape (len(time), len(names))
    notes: List[str]
    steps: Optional[Table] = None
    units: Dict[str, Optional[str]] = field(init=False)

    def __post_init__(self) -> None:
        # The variable's own name after the element's (`gear.pinion_speed` → pinion_speed)
        # where geardyn knows it; a third-party FMU's variables have no unit here.
        self.units = {
            n: _geardyn.column_unit(n) or _geardyn.column_unit(n.split(".", 1)[-1])
            for n in ["time", *self.names]
        }

    def to_structured(self) -> np.ndarray:
        """The result as fmpy's ``simulate_fmu`` returns it: a structured array with a
        ``time`` field and one field per variable."""
        dtype = [("time", float)] + [(n, float) for n in self.names]
        out = np.empty(len(self.time), dtype=dtype)
        out["time"] = self.time
        for i, n in enumerate(self.names):
            out[n] = self.data[:, i]
        return out


def _write_input(path: Path, signals) -> None:
    """fmpy's input convention to the CSV ``geardyn run --input`` reads: a structured array
    with a ``time`` field and one field per input (or a dict of equal-length arrays), written
    with 17 significant digits, so every double reaches the run exactly."""
    if isinstance(signals, dict):
        names = list(signals)
        columns = [np.asarray(signals[n]) for n in names]
    else:
        arr = np.asarray(signals)
        if arr.dtype.names is None:
            raise GeardynError(
                "input: expected a structured array with a 'time' field and one field per "
                "input (fmpy's convention), or a dict of arrays"
            )
        names = list(arr.dtype.names)
        columns = [arr[n] for n in names]
    if "time" not in names:
        raise GeardynError(f"input: no 'time' field (fields: {', '.join(names)})")
    lengths = {len(c) for c in columns}
    if len(lengths) != 1:
        raise GeardynError(f"input: the fields have different lengths {sorted(lengths)}")
    order = [names.index("time")] + [i for i, n in enumerate(names) if n != "time"]
    with open(path, "w") as f:
        f.write(",".join(names[i] for i in order) + "\n")
        for row in zip(*(columns[i] for i in order)):
            f.write(",".join(_csv_number(v) for v in row) + "\n")


def _csv_number(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "1" if v else "0"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))


def _captured_stderr(call):
    """Runs ``call()`` with the process's standard error (file descriptor 2, where the run
    and its supervised FMU process print) going to a file; returns what it returned and the
    lines printed."""
    import sys

    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            result = call()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        tmp.seek(0)
        lines = tmp.read().decode("utf-8", "replace").splitlines()
    return result, [line for line in lines if line.strip()]


def run(
    fmu: Union[str, os.PathLike],
    start_time: Optional[float] = None,
    stop_time: Optional[float] = None,
    output_interval: Optional[float] = None,
    start_values: Optional[Dict[str, Union[float, int, bool, str]]] = None,
    input=None,
    output: Optional[List[str]] = None,
    max_rows: Optional[int] = None,
    log_level: str = "warning",
    algorithm: Optional[str] = None,
    extrapolation: Optional[str] = None,
    threads: Optional[int] = None,
    divergence_factor: Optional[float] = None,
    tolerance: Optional[float] = None,
    min_step: Optional[float] = None,
    max_step: Optional[float] = None,
) -> FmuRun:
    """Runs any FMI 2.0 Co-Simulation FMU, or a system of FMUs (an ``.ssp``, a
    ``SystemStructure.ssd`` or a folder holding one), as ``geardyn run`` does, with fmpy's
    argument names: ``start_values`` (name → value; in a system ``Element.variable``),
    ``input`` (a structured array with a ``time`` field and one field per input, or a dict of
    arrays: continuous Reals interpolated linearly at each step start, others held), ``output``
    (the variables to record). The system options (``algorithm``, ``extrapolation``,
    ``threads``, ``divergence_factor``, ``tolerance``, ``min_step``, ``max_step``) are the
    CLI's (docs/systems.md, docs/cosimulation.md). The CLI's rows, bit for bit.

    The run's notes and the FMU's log lines become ``RuntimeWarning``s (and ``notes``); a
    failed run raises :class:`GeardynError` with the run's message."""
    import warnings

    starts = []
    for name, value in (start_values or {}).items():
        text = value if isinstance(value, str) else _csv_number(value)
        starts.append(f"{name}={text}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "run.csv"
        input_path = None
        if input is not None:
            input_path = Path(tmp) / "input.csv"
            _write_input(input_path, input)

        def call():
            return _geardyn.run(
                os.fspath(fmu), os.fspath(out), start_time, stop_time, output_interval,
                max_rows, starts, None if input_path is None else os.fspath(input_path),
                None if output is None else list(output), log_level, algorithm, extrapolation,
                threads, divergence_factor, tolerance, min_step, max_step)

        status, lines = _captured_stderr(call)
        # The temporary files of this call are named as what they are here: the input
        # argument, and the result's `steps`.
        if input_path is not None:
            lines = [line.replace(f"{input_path}:", "input:") for line in lines]
        lines = [_geardyn._pythonic(line.replace(f"in {out}.steps.csv", "FmuRun.steps"))
                 for line in lines]
        errors = [line[len("error: "):] for line in lines if line.startswith("error: ")]
        if status != 0:
            notes = [line for line in lines if not line.startswith("error: ")]
            raise GeardynError("\n".join(errors + notes) or f"the run ended with status {status}")
        for line in lines:
            warnings.warn(line.removeprefix("warning: "), RuntimeWarning, stacklevel=2)
        columns, data, _ = _read_table(out)
        steps_path = Path(f"{out}.steps.csv")
        steps = None
        if steps_path.exists():
            s_columns, s_data, _ = _read_table(steps_path)
            steps = Table(s_columns, s_data)
    return FmuRun(columns[1:], data[:, 0], data[:, 1:], notes=lines, steps=steps)
