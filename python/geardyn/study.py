"""Parameter studies of a geardyn scene on Dask distributed (``geardyn-study run study.toml``).

A study file names a base scene, the parameters to vary (a grid, a Latin hypercube or Monte
Carlo draws from named distributions, with a seed), the analysis run at each point
(``simulate``, ``periodic`` steady state, or a ``sweep``) and the scalar results to keep. The
format is in docs/python.md.

Why it is shaped this way:

* Dask does the scheduling, the retries of tasks whose worker died, and the scaling to many
  machines (``--scheduler ADDRESS``); this module only cuts the study into tasks, stores what
  comes back and reports.
* Every point is keyed by a hash of (base scene, analysis, parameter values). Results are
  appended to a Parquet dataset (one file per flush, written to a temporary name and renamed)
  as they arrive, so a run that is stopped — Ctrl-C, a dead client, a lost machine — and
  started again computes only the keys that are not stored yet.
* The points are drawn on the client from the seed before anything is scheduled, and each
  point's solve is deterministic, so the stored results are bit-identical whatever the
  number of workers or the order in which tasks finish.
* A point whose solve fails is stored with its error message and NaN results: one bad corner
  of a design space does not stop the study.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import itertools
import json
import math
import os
import sys
import threading
import time
import tomllib
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Union

import numpy as np

import geardyn

ANALYSES = ("simulate", "periodic", "sweep", "hb", "modes", "spectrum")

# Sweep results of the whole branch, not of one mesh of a drivetrain.
BRANCH_WIDE = {"unconverged"}

# Scalar results per analysis, with what each means (also the docs' table).
RESULTS = {
    # Over the run, from the continuous solution: `geardyn simulate`'s summary (event times,
    # integrals over each smooth piece, refined extremes; `Simulation.statistics`). Only a
    # scene with speed or torque profiles falls back to the output samples.
    "simulate": {
        "dte_rms": "RMS of the DTE with its mean removed, m",
        "dte_mean": "mean DTE, m",
        "dte_peak_to_peak": "peak-to-peak DTE, m",
        "peak_force": "largest |mesh force|, N",
        "dynamic_factor": "peak mesh force over the static mesh force, 1",
        "contact_loss_fraction": "fraction of the run with no tooth pair in contact, from the "
        "event times, 1",
    },
    "periodic": {
        "floquet_max": "largest Floquet multiplier magnitude (spectral radius), 1",
        "stable": "1 if the orbit is stable, else 0, 1",
        "period": "orbit period, s",
        "dte0": "DTE on the orbit at t = 0, m",
    },
    "sweep": {
        "peak_dte_rms": "largest DTE RMS over the sweep, m",
        "peak_mesh_frequency": "mesh frequency of that largest DTE RMS, Hz",
        "hysteresis": "largest |up − down| DTE RMS at one speed (jump region), m",
        "max_contact_loss_fraction": "largest contact-loss fraction over the sweep, 1",
        "unconverged": "points without a periodic steady state, 1",
    },
    # The harmonic-balance branch over `speed = "from:to"` (`geardyn hb`); over all meshes of
    # a drivetrain.
    "hb": {
        "peak_dte_rms": "largest DTE RMS on the branch, m",
        "peak_mesh_frequency": "mesh frequency of that largest DTE RMS, Hz",
        "folds": "fold points (turning points) of the branch, 1",
        "unstable_points": "branch points whose orbit is unstable (Hill's method), 1",
    },
    # Natural frequencies of the mean-stiffness modes (`geardyn modes`), rigid-body modes
    # (zero frequency) left out.
    "modes": {
        "f1": "lowest natural frequency, Hz",
        "f2": "second natural frequency, Hz",
        "f3": "third natural frequency, Hz",
        "f4": "fourth natural frequency, Hz",
    },
    # Lines of the exact steady-state DTE spectrum (`geardyn spectrum`), per mesh of a
    # drivetrain (`<mesh>.mesh_order_1`, at that mesh's own orders).
    "spectrum": {
        "mesh_order_1": "DTE amplitude at the mesh frequency, m",
        "mesh_order_2": "DTE amplitude at twice the mesh frequency, m",
        "mesh_order_3": "DTE amplitude at three times the mesh frequency, m",
    },
}

DISTRIBUTIONS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "lognormal": ("median", "sigma"),
    "triangular": ("low", "mode", "high"),
}


# Most points of a study (grid points or samples): every point is a solve and a stored row,
# and the points are listed in memory before they are submitted. Checked before anything is
# allocated (issue 34).
MAX_POINTS = 1_000_000


class StudyError(ValueError):
    """A study file that cannot be run; the message names the field and value."""


@dataclass
class Parameter:
    """A scene path and how it varies: grid ``values``, or a ``distribution``."""

    path: str
    # Grid values as written: numbers, whole numbers (``gear[0].teeth``), strings (a stiffness
    # kind) or booleans; each reaches the scene with its type.
    values: Optional[List[Union[float, int, str, bool]]] = None
    distribution: Optional[str] = None
    args: Dict[str, float] = field(default_factory=dict)
    # Grid parameters of one group vary together (a linked parameter: `path = [...]` with one
    # list of values per point, e.g. a gear's teeth with its base radius); the grid is the
    # product over groups.
    group: int = 0

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Maps uniform draws u in (0, 1) through the distribution's inverse CDF (so LHS and
        Monte Carlo share the distributions, and the draws depend on the seed alone)."""
        from scipy import stats

        a = self.args
        d = self.distribution
        if d == "uniform":
            return a["low"] + (a["high"] - a["low"]) * u
        if d == "normal":
            return stats.norm.ppf(u, loc=a["mean"], scale=a["std"])
        if d == "lognormal":
            return a["median"] * np.exp(a["sigma"] * stats.norm.ppf(u))
        if d == "triangular":
            c = (a["mode"] - a["low"]) / (a["high"] - a["low"])
            return stats.triang.ppf(u, c, loc=a["low"], scale=a["high"] - a["low"])
        raise AssertionError(d)


@dataclass
class Study:
    """A parsed study file. ``points()`` are the parameter values of every point, in order."""

    path: Path
    scene_path: Path
    scene_text: str
    method: str
    parameters: List[Parameter]
    samples: Optional[int]
    seed: Optional[int]
    analysis: Dict[str, object]
    results: List[str]
    store: Path
    chunk: Optional[int]
    # User outputs: name -> callable on the analysis' result (a `Simulation`, an `Orbit` or the
    # sweep's `Table`) returning a number; `[[output]]` entries of the file or `load(...,
    # outputs=)`.
    outputs: Dict[str, Callable] = field(default_factory=dict)
    # Units of user outputs that have one (`[[output]] unit`, `load(outputs={name: (f, unit)})`).
    output_units: Dict[str, str] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        return str(self.analysis["kind"])

    def base_scene(self) -> "geardyn.Scene":
        return geardyn.Scene.from_toml(self.scene_text, origin=str(self.scene_path))

    def points(self) -> List[Dict[str, float]]:
        names = [p.path for p in self.parameters]
        if self.method == "grid":
            axes = [[p for p in self.parameters if p.group == g] for g in self.groups()]
            choices = [[{p.path: p.values[k] for p in axis} for k in range(len(axis[0].values))] for axis in axes]
            return [{k: v for part in parts for k, v in part.items()} for parts in itertools.product(*choices)]
        rng = np.random.Generator(np.random.PCG64(self.seed))
        n, d = self.samples, len(self.parameters)
        if self.method == "lhs":
            # One draw per stratum in every dimension, strata paired by random permutations.
            u = (np.stack([rng.permutation(n) for _ in range(d)], axis=1) + rng.random((n, d))) / n
        else:
            u = rng.random((n, d))
        columns = [p.from_unit(u[:, j]) for j, p in enumerate(self.parameters)]
        return [dict(zip(names, (float(c[i]) for c in columns))) for i in range(n)]

    def groups(self) -> List[int]:
        """The grid's axes in order: one group per `[[parameter]]` (linked paths share one)."""
        return list(dict.fromkeys(p.group for p in self.parameters))

    def axes(self) -> List[str]:
        """The first path of each axis (what a plot is drawn over)."""
        return [next(p.path for p in self.parameters if p.group == g) for g in self.groups()]

    def key(self, point: Dict[str, float]) -> str:
        """The point's identity: base scene text, analysis, the results kept and exact
        parameter values. The results are part of it: a row stored for other results lacks
        columns, and must not pass for this study's (its columns would read NaN)."""
        identity = {"scene": self.scene_text, "analysis": self.analysis,
                    "results": list(self.results), "point": point}
        if self.outputs:
            identity["outputs"] = {n: _qualified_name(f) for n, f in self.outputs.items()}
        blob = json.dumps(identity, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:24]

    def units(self) -> Dict[str, Optional[str]]:
        """The unit of every parameter and result column (None where there is none): the
        scene format's for a parameter (:func:`geardyn.unit`), the last part of the result's
        description in :data:`RESULTS`, a user output's own. UDUNITS and pint read them."""
        units = {p.path: geardyn.unit(p.path) for p in self.parameters}
        for c in self.result_columns():
            r = c.rsplit(".", 1)[-1]
            if c in self.outputs:
                units[c] = self.output_units.get(c)
            elif r in RESULTS[self.kind]:
                units[c] = result_unit(self.kind, r)
        return units

    def result_columns(self) -> List[str]:
        """The stored result columns: per mesh of a drivetrain (``<mesh>.dte_rms``) for the
        results that belong to a mesh, then the branch-wide ones and the user outputs."""
        if self.kind in ("simulate", "spectrum", "sweep") and self.base_scene().is_train:
            meshes = _train_meshes(self.base_scene())
            per_mesh = [r for r in self.results if r not in BRANCH_WIDE]
            return ([f"{m}.{r}" for m in meshes for r in per_mesh]
                    + [r for r in self.results if r in BRANCH_WIDE] + list(self.outputs))
        return list(self.results) + list(self.outputs)


def result_unit(kind: str, name: str) -> str:
    """The unit of a study result: by convention the last comma-separated part of its
    description in :data:`RESULTS` (checked for every result by tests/python/test_study_units.py)."""
    return RESULTS[kind][name].rsplit(", ", 1)[-1]


def _need(table: dict, key: str, where: str):
    if key not in table:
        raise StudyError(f"{where}: missing '{key}'")
    return table[key]


def _grid_value(v, where: str):
    """A grid value with its type: a finite number (a whole number stays one, for integer
    parameters such as ``gear[0].teeth``), a string (``mesh.stiffness.kind``) or a boolean."""
    if isinstance(v, (bool, str)):
        return v
    if isinstance(v, int):
        return v
    return _number(v, where)


def _in_scene_units(path: str, v, where: str):
    """A value written with a unit (``"4500rpm"``, ``"0.1 mm"``) for a parameter the scene
    format gives a unit: the number in that unit, so the store holds SI values."""
    from . import _quantity

    if not isinstance(v, str) or geardyn._geardyn.parameter_unit(path) is None:
        return v
    try:
        return _quantity.to_si(path, v)
    except geardyn.GeardynError as e:
        raise StudyError(f"{where}: {e}") from None


def _grid_values(raw, where: str, path: str) -> list:
    """A grid's values, each with its type; all numbers, all strings or all booleans.
    Values with units are converted to the scene's unit for ``path``."""
    if not isinstance(raw, list):
        raise StudyError(f"{where} = {raw!r}: must be a list")
    values = [_grid_value(_in_scene_units(path, v, where), where) for v in raw]
    kinds = {"boolean" if isinstance(v, bool) else "string" if isinstance(v, str) else "number" for v in values}
    if len(kinds) > 1:
        raise StudyError(f"{where} = {raw!r}: mixes {' and '.join(k + 's' for k in sorted(kinds))}")
    return values


def _linked(p: dict, paths: list, at: str, group: int, method: str) -> List["Parameter"]:
    """`path = ["gear[0].teeth", "gear[0].base_radius"]`, `values = [[36, 0.04297], ...]`:
    paths that vary together, one row of values per grid step."""
    if method != "grid":
        raise StudyError(f"{at}.path = {paths!r}: linked paths are a grid parameter (values = [[...], ...])")
    if not paths or not all(isinstance(q, str) for q in paths) or len(set(paths)) != len(paths):
        raise StudyError(f"{at}.path = {paths!r}: must be a list of distinct scene paths")
    extra = sorted(set(p) - {"path", "values"})
    if extra:
        raise StudyError(f"{at}.{extra[0]}: linked paths take values = [[...], ...] only")
    rows = _need(p, "values", at)
    if not isinstance(rows, list) or not rows:
        raise StudyError(f"{at}.values: a non-empty list of rows, one value per path")
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != len(paths):
            raise StudyError(f"{at}.values[{k}] = {row!r}: must list {len(paths)} values, one per path {paths}")
    return [Parameter(q, values=_grid_values([row[j] for row in rows], f"{at}.values[*][{j}] ({q})", q), group=group)
            for j, q in enumerate(paths)]


def _arrow_type(values: Sequence):
    """The store's column type of a parameter: int64, bool or string where every value is
    one, else float64."""
    import pyarrow as pa

    if values and all(isinstance(v, bool) for v in values):
        return pa.bool_()
    if values and all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return pa.int64()
    if values and all(isinstance(v, str) for v in values):
        return pa.string()
    return pa.float64()


def _number(v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise StudyError(f"{where} = {v!r}: must be a finite number")
    return float(v)


def _qualified_name(f: Callable) -> str:
    return f"{getattr(f, '__module__', '?')}:{getattr(f, '__qualname__', repr(f))}"


def _unit_text(unit, where: str) -> str:
    if not isinstance(unit, str) or not unit.strip():
        raise StudyError(f"{where} = {unit!r}: a unit is a non-empty string such as \"m\" or \"N.m\"")
    return unit


def _import_output(spec: str, where: str) -> Callable:
    """`package.module:function` of an `[[output]]` entry (importable on every worker)."""
    import importlib

    module, _, name = spec.partition(":")
    if not module or not name:
        raise StudyError(f"{where} = {spec!r}: write the function as 'package.module:function'")
    try:
        f = importlib.import_module(module)
        for part in name.split("."):
            f = getattr(f, part)
    except (ImportError, AttributeError) as e:
        raise StudyError(f"{where} = {spec!r}: {e}") from None
    if not callable(f):
        raise StudyError(f"{where} = {spec!r}: not callable")
    return f


def load(path, outputs: Optional[Dict[str, Callable]] = None) -> Study:
    """Reads and checks a study file; paths in it are relative to the file. ``outputs`` adds
    user outputs: ``{"name": f}`` with ``f(result) -> number`` called on each point's result
    (a :class:`geardyn.Simulation`, :class:`geardyn.Orbit` or the sweep's
    :class:`geardyn.Table`); a function defined in a script is shipped to the workers by
    Dask."""
    path = Path(path).resolve()
    try:
        data = tomllib.loads(path.read_text())
    except OSError as e:
        raise StudyError(f"cannot read study file '{path}': {e}") from None
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{path}: {e}") from None
    where = str(path)
    known = {"scene", "seed", "store", "chunk", "sampling", "parameter", "analysis", "results", "output"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise StudyError(f"{where}: unknown key '{unknown[0]}' (known: {', '.join(sorted(known))})")
    scene_path = (path.parent / _need(data, "scene", where)).resolve()
    scene_file = scene_path / "scene.toml" if scene_path.is_dir() else scene_path
    try:
        scene_text = scene_file.read_text()
    except OSError as e:
        raise StudyError(f"{where}: scene = '{data['scene']}': {e}") from None
    # Validates the base scene now, with the CLI's message, before any worker starts.
    geardyn.Scene.from_toml(scene_text, origin=str(scene_file))

    sampling = data.get("sampling", {})
    method = sampling.get("method", "grid")
    if method not in ("grid", "lhs", "monte_carlo"):
        raise StudyError(f"sampling.method = {method!r}: must be grid, lhs or monte_carlo")
    samples = seed = None
    if method != "grid":
        samples = sampling.get("samples")
        if not isinstance(samples, int) or isinstance(samples, bool) or samples < 1:
            raise StudyError(f"sampling.samples = {samples!r}: {method} needs a whole number of samples >= 1")
        if samples > MAX_POINTS:
            raise StudyError(f"sampling.samples = {samples}: more than the {MAX_POINTS} points a study may have")
        seed = data.get("seed")
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise StudyError(f"seed = {seed!r}: {method} needs a seed (a whole number >= 0)")
    for k in sampling:
        if k not in ("method", "samples"):
            raise StudyError(f"sampling.{k}: unknown key (method, samples)")

    parameters = []
    for i, p in enumerate(_need(data, "parameter", where)):
        at = f"parameter[{i}]"
        name = _need(p, "path", at)
        if isinstance(name, list):
            parameters.extend(_linked(p, name, at, i, method))
            continue
        if not isinstance(name, str):
            raise StudyError(f"{at}.path = {name!r}: must be a scene path or a list of them")
        if method == "grid":
            if "values" in p:
                values = _grid_values(p["values"], f"{at}.values", name)
            elif {"from", "to", "points"} <= set(p):
                points = p["points"]
                if not isinstance(points, int) or isinstance(points, bool) or points < 1:
                    raise StudyError(f"{at}.points = {points!r}: must be a whole number >= 1")
                if points > MAX_POINTS:
                    raise StudyError(f"{at}.points = {points}: more than the {MAX_POINTS} points a study may have")
                lo = _number(_in_scene_units(name, p["from"], f"{at}.from"), f"{at}.from")
                hi = _number(_in_scene_units(name, p["to"], f"{at}.to"), f"{at}.to")
                values = [lo] if points == 1 else [lo + (hi - lo) * k / (points - 1) for k in range(points)]
            else:
                raise StudyError(f"{at} ({name}): a grid parameter needs values = [...] or from, to, points")
            if not values:
                raise StudyError(f"{at}.values: empty")
            parameters.append(Parameter(name, values=values, group=i))
        else:
            dist = _need(p, "distribution", at)
            if dist not in DISTRIBUTIONS:
                raise StudyError(f"{at}.distribution = {dist!r}: must be one of {', '.join(DISTRIBUTIONS)}")
            args = {a: _number(_need(p, a, f"{at} ({dist})"), f"{at}.{a}") for a in DISTRIBUTIONS[dist]}
            extra = sorted(set(p) - {"path", "distribution", *DISTRIBUTIONS[dist]})
            if extra:
                raise StudyError(f"{at}.{extra[0]}: not a parameter of the {dist} distribution")
            bad = (
                (dist in ("uniform", "triangular") and not args["low"] < args["high"])
                or (dist == "triangular" and not args["low"] <= args["mode"] <= args["high"])
                or (dist == "normal" and not args["std"] > 0)
                or (dist == "lognormal" and not (args["median"] > 0 and args["sigma"] > 0))
            )
            if bad:
                raise StudyError(f"{at} ({name}): {dist} {args} is not a distribution")
            parameters.append(Parameter(name, distribution=dist, args=args, group=i))
    names = [p.path for p in parameters]
    if len(set(names)) != len(names):
        raise StudyError(f"{where}: a parameter is varied twice ({names})")

    analysis = dict(_need(data, "analysis", where))
    kind = analysis.get("kind")
    if kind not in ANALYSES:
        raise StudyError(f"analysis.kind = {kind!r}: must be one of {', '.join(ANALYSES)}")
    allowed = {
        "simulate": set(),
        "periodic": {"periods", "warmup", "speed"},
        "sweep": {"speed", "direction", "tolerance", "max_periods"},
        "hb": {"speed", "harmonics", "subharmonic"},
        "modes": {"rigid_bearings"},
        "spectrum": {"samples", "periods"},
    }[kind]
    # modes and spectrum take no time limit: modes is one eigenproblem, and spectrum's
    # orbit is bounded by the scene's work budget.
    if kind not in ("modes", "spectrum"):
        allowed = allowed | {"timeout"}
    # Columns of the analysis' result kept whole per point (a run's traces, a spectrum's
    # lines, a sweep's curve), in the study's Zarr store.
    if kind in ("simulate", "sweep", "hb", "spectrum"):
        allowed = allowed | {"arrays"}
    extra = sorted(set(analysis) - allowed - {"kind"})
    if extra:
        raise StudyError(f"analysis.{extra[0]}: not an option of {kind} ({', '.join(sorted(allowed)) or 'none'})")
    if "timeout" in analysis:
        t = analysis["timeout"]
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not (math.isfinite(t) and t > 0):
            raise StudyError(f"analysis.timeout = {t!r}: must be a number of seconds > 0 "
                             "(each point's solve is stopped then and the point recorded as failed)")
    if kind == "sweep" and "speed" not in analysis:
        raise StudyError("analysis.speed: a sweep needs speed = \"from:to:points\" "
                         "(e.g. \"1000rpm:5000rpm:41\"; bare numbers are rad/s)")
    arrays = analysis.get("arrays", [])
    if not isinstance(arrays, list) or not all(isinstance(a, str) and a for a in arrays) \
            or len(set(arrays)) != len(arrays):
        raise StudyError(f"analysis.arrays = {arrays!r}: must be a list of distinct column names "
                         "of the analysis' result (e.g. [\"time\", \"mesh.dte\"])")
    if kind == "hb" and "speed" not in analysis:
        raise StudyError("analysis.speed: hb needs speed = \"from:to\" "
                         "(e.g. \"3000rpm:6000rpm\"; bare numbers are rad/s)")
    if kind == "periodic" and "dte0" in data.get("results", []) and \
            geardyn.Scene.from_toml(scene_text, origin=str(scene_file)).is_train:
        raise StudyError("results: 'dte0' (the DTE at the orbit's start) is a single pair's; a "
                         "drivetrain's orbit has one per mesh: use a user output on the Orbit")
    if kind == "periodic" and "speed" in analysis and "operating.pinion_speed" in names:
        raise StudyError("analysis.speed: the pinion speed is also a varied parameter; give one of them")

    results = _need(data, "results", where)
    for r in results:
        if r not in RESULTS[kind]:
            raise StudyError(f"results: {r!r} is not a result of {kind} ({', '.join(RESULTS[kind])})")
    user = {}
    output_units: Dict[str, str] = {}
    for i, o in enumerate(data.get("output", [])):
        at = f"output[{i}]"
        extra = sorted(set(o) - {"name", "function", "unit"})
        if extra:
            raise StudyError(f"{at}.{extra[0]}: unknown key (name, function, unit)")
        name = str(_need(o, "name", at))
        user[name] = _import_output(str(_need(o, "function", at)), f"{at}.function")
        if "unit" in o:
            output_units[name] = _unit_text(o["unit"], f"{at}.unit")
    for name, f in (outputs or {}).items():
        if isinstance(f, tuple) and len(f) == 2:
            f, output_units[name] = f[0], _unit_text(f[1], f"outputs[{name!r}] unit")
        if not callable(f):
            raise StudyError(f"outputs[{name!r}] = {f!r}: not callable")
        if name in user:
            raise StudyError(f"outputs[{name!r}]: also an [[output]] of the file")
        user[name] = f
    clash = sorted(set(user) & (set(RESULTS[kind]) | set(names) | {"index", "key", "error"}))
    if clash:
        raise StudyError(f"output {clash[0]!r}: the name of a result or parameter column")
    store = path.parent / data.get("store", path.stem + ".parquet")
    chunk = data.get("chunk")
    if method == "grid":
        sizes_by_group = {p.group: len(p.values) for p in parameters}
        total = math.prod(sizes_by_group.values())
        if total > MAX_POINTS:
            sizes = " × ".join(str(n) for n in sizes_by_group.values())
            raise StudyError(f"{where}: the grid has {sizes} = {total} points, more than the {MAX_POINTS} a study may have")
    if chunk is not None and (not isinstance(chunk, int) or chunk < 1):
        raise StudyError(f"chunk = {chunk!r}: must be a whole number >= 1 (points per task)")
    study = Study(path, scene_file, scene_text, method, parameters, samples, seed, analysis,
                  list(results), store, chunk, user, output_units)
    # A misspelt path fails at every point: catch it now rather than store a study of
    # errors. Single bad points are data (stored with their error), so one good point of
    # the first 100 is enough.
    first_error = None
    for point in itertools.islice(study.points(), 100):
        try:
            study.base_scene().update(point)
            break
        except geardyn.GeardynError as e:
            first_error = first_error or f"point {point}: {e}"
    else:
        raise StudyError(f"{where}: no point of the first 100 makes a valid scene; {first_error}")
    return study


def _train_meshes(scene) -> List[str]:
    return [m["name"] for m in scene.to_dict()["mesh"]]


# --------------------------------------------------------------------------------------
# One point (runs on the workers)


@functools.lru_cache(maxsize=8)
def _base(scene_text: str, origin: str) -> "geardyn.Scene":
    """The validated base scene, parsed once per worker process and study."""
    return geardyn.Scene.from_toml(scene_text, origin=origin)


def _simulate_results(scene, run, results: Sequence[str]) -> Dict[str, float]:
    if run.statistics_source != "output samples":
        # The summary of `geardyn simulate`, bit for bit (a drivetrain's per mesh).
        out = {}
        for m in run.statistics:
            prefix = f"{m['name']}." if scene.is_train else ""
            out.update({prefix + r: float(m[r]) for r in results})
        return out
    # Speed or torque profiles: the output samples.
    if scene.is_train:
        out = {}
        for m in _train_meshes(scene):
            contact = run[f"{m}.pairs_in_contact"] == 0
            out.update(_series_results(run[f"{m}.dte"], run[f"{m}.force"], contact, results, prefix=f"{m}."))
        return out
    return _series_results(run["mesh.dte"], run["mesh.force"], run["mesh.contact_state"] != 1, results)


def _series_results(dte, force, lost, results, prefix="") -> Dict[str, float]:
    values = {
        "dte_rms": lambda: float(np.sqrt(np.mean((dte - dte.mean()) ** 2))),
        "dte_mean": lambda: float(dte.mean()),
        "dte_peak_to_peak": lambda: float(dte.max() - dte.min()),
        "peak_force": lambda: float(np.abs(force).max()),
        "dynamic_factor": lambda: float(np.abs(force).max() / abs(force.mean())),
        "contact_loss_fraction": lambda: float(lost.mean()),
    }
    return {prefix + r: values[r]() for r in results}


def _sweep_results(table, results, meshes: Sequence[str] = ()) -> Dict[str, float]:
    """The sweep's results; for a drivetrain (``meshes``) per mesh, from its own columns."""
    out = {}
    if "unconverged" in results:
        out["unconverged"] = float((table["converged"] == 0).sum())
    for prefix in [f"{m}." for m in meshes] or [""]:
        rms, d = table[prefix + "dte_rms"], table["direction"]
        f = table[prefix + "mesh_frequency"]
        i = int(np.argmax(rms))
        up, down = {}, {}
        for s, r, di in zip(table["speed"], rms, d):
            (up if di > 0 else down)[s] = r
        common = sorted(set(up) & set(down))
        values = {
            "peak_dte_rms": float(rms[i]),
            "peak_mesh_frequency": float(f[i]),
            "hysteresis": float(max((abs(up[s] - down[s]) for s in common), default=0.0)),
            "max_contact_loss_fraction": float(table[prefix + "contact_loss_fraction"].max()),
        }
        out.update({prefix + r: values[r] for r in results if r in values})
    return out


def _hb_results(table, results) -> Dict[str, float]:
    rms_columns = [c for c in table.columns if c == "dte_rms" or c.endswith(".dte_rms")]
    rms = np.max(np.stack([table[c] for c in rms_columns]), axis=0)
    i = int(np.argmax(rms))
    values = {
        "peak_dte_rms": float(rms[i]),
        "peak_mesh_frequency": float(table["mesh_frequency"][i]),
        "folds": float((table["fold"] != 0).sum()),
        "unstable_points": float((table["stable"] == 0).sum()),
    }
    return {r: values[r] for r in results}


def _modes_results(modes, results) -> Dict[str, float]:
    f = np.sort(np.asarray(modes.frequencies, dtype=float))
    # Rigid-body modes: zero up to the eigensolver's rounding against the largest frequency.
    elastic = f[f > 1e-9 * f.max()] if f.size and f.max() > 0 else f[:0]
    out = {}
    for r in results:
        k = int(r[1:])
        if k > elastic.size:
            raise StudyError(f"results: {r!r}: the scene has {elastic.size} elastic mode(s)")
        out[r] = float(elastic[k - 1])
    return out


def _spectrum_results(scene, spectrum, results) -> Dict[str, float]:
    """Each mesh's DTE line at k times its own mesh frequency. Lines are found by frequency,
    not label: where orders coincide (the idler's two meshes share one frequency; a shaft
    order may be a mesh order) the spectrum names the line once."""
    frequency = np.asarray(spectrum["frequency_Hz"], dtype=float)
    out = {}
    for m, fm in scene.mesh_frequencies:
        prefix = f"{m}." if scene.is_train else ""
        amplitude = spectrum[f"{m}.dte_amplitude_m"]
        for r in results:
            k = int(r.rsplit("_", 1)[1])
            j = int(np.argmin(np.abs(frequency - k * fm)))
            if abs(frequency[j] - k * fm) > 1e-9 * k * fm:
                raise StudyError(f"results: {r!r}: the spectrum has no line at {k} × {fm:.6g} Hz "
                                 f"({m}); raise samples")
            out[prefix + r] = float(amplitude[j])
    return out


# The record key under which a point's arrays travel from the worker to the client.
ARRAYS = "__arrays__"


def run_point(scene_text: str, origin: str, analysis: dict, results: Sequence[str],
              point: Dict[str, float], outputs: Optional[Dict[str, Callable]] = None) -> Dict[str, float]:
    """Runs one point and returns its scalar results and user outputs; raises what the
    solve raises."""
    scene = _base(scene_text, origin).copy()
    values = dict(point)
    if analysis["kind"] == "periodic" and "speed" in analysis:
        values["operating.pinion_speed"] = geardyn.parse_speed(analysis["speed"])
    scene.update(values)
    kind = analysis["kind"]
    timeout = analysis.get("timeout")
    if kind == "simulate":
        result = geardyn.simulate(scene, timeout=timeout)
        out = _simulate_results(scene, result, results)
    elif kind == "periodic":
        result = geardyn.periodic(scene, periods=int(analysis.get("periods", 1)),
                                  warmup=int(analysis.get("warmup", 20)), timeout=timeout)
        values = {
            "floquet_max": float(result.spectral_radius),
            "stable": 1.0 if result.stability == "Stable" else 0.0,
            "period": float(result.period),
            "dte0": float(result.y0[0]),
        }
        out = {r: values[r] for r in results}
    elif kind == "sweep":
        result = geardyn.sweep(scene, str(analysis["speed"]), str(analysis.get("direction", "both")),
                               float(analysis.get("tolerance", 1e-7)), int(analysis.get("max_periods", 3000)),
                               timeout=timeout)
        out = _sweep_results(result, results, _train_meshes(scene) if scene.is_train else ())
    elif kind == "hb":
        result = geardyn.hb(scene, str(analysis["speed"]), int(analysis.get("harmonics", 20)),
                            int(analysis.get("subharmonic", 1)), timeout=timeout)
        out = _hb_results(result, results)
    elif kind == "modes":
        result = geardyn.modes(scene, bool(analysis.get("rigid_bearings", False)))
        out = _modes_results(result, results)
    else:
        result = geardyn.spectrum(scene, samples=int(analysis.get("samples", 64)),
                                  periods=int(analysis.get("periods", 1)))
        out = _spectrum_results(scene, result, results)
    arrays = {}
    for name in analysis.get("arrays", []):
        columns = ["time", *result.names] if hasattr(result, "names") else result.columns
        if name not in columns:
            raise StudyError(f"analysis.arrays: {name!r} is not a column of the {kind} result "
                             f"({', '.join(columns)})")
        arrays[name] = np.asarray(result[name], dtype=float)
    for name, f in (outputs or {}).items():
        value = f(result)
        if isinstance(value, (bool, int, float, np.bool_, np.integer, np.floating)):
            out[name] = float(value)
        elif isinstance(value, np.ndarray) and value.ndim == 1 and np.issubdtype(value.dtype, np.number):
            arrays[name] = np.asarray(value, dtype=float)
        else:
            raise StudyError(f"output {name!r} returned {value!r} ({type(value).__name__}): must be a "
                             "number or a one-dimensional numeric NumPy array")
    if arrays:
        out[ARRAYS] = arrays
    return out


def run_chunk(scene_text: str, origin: str, analysis: dict, results: Sequence[str],
              columns: Sequence[str], points: Sequence[tuple],
              outputs: Optional[Dict[str, Callable]] = None) -> tuple:
    """A Dask task: several points (index, key, values) in one task so the per-task cost of
    the scheduler is spread; a failing point is recorded with its error and NaN results.
    Returns the records and the task's solve time (it sizes the next tasks; it is not
    stored, so the store stays bit-identical from run to run)."""
    start = time.perf_counter()
    records = []
    for index, key, point in points:
        try:
            values = run_point(scene_text, origin, analysis, results, point, outputs)
            records.append({"index": index, "key": key, **point,
                            **{c: values[c] for c in columns if c in values}, "error": None,
                            **({ARRAYS: values[ARRAYS]} if ARRAYS in values else {})})
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as e:  # noqa: BLE001 -- a failure (a Rust panic too) is data
            message = str(e) if isinstance(e, geardyn.GeardynError) else f"{type(e).__name__}: {e}"
            records.append(_failed(index, key, point, columns, message))
    return records, time.perf_counter() - start


def _failed(index: int, key: str, point: Dict[str, float], columns: Sequence[str], message: str) -> dict:
    return {"index": index, "key": key, **point, **{c: math.nan for c in columns}, "error": message}


# --------------------------------------------------------------------------------------
# The store


def stored(store: Path):
    """Everything stored so far as a DataFrame (empty if nothing is); the columns' units, as
    the store's field metadata has them, in ``df.attrs["units"]``."""
    import pandas as pd
    import pyarrow.parquet as pq

    parts = sorted(store.glob("part-*.parquet")) if store.is_dir() else []
    if not parts:
        return pd.DataFrame()
    tables = [pq.read_table(p) for p in parts]
    units = {}
    for t in tables:
        for f in t.schema:
            if f.metadata and b"unit" in f.metadata:
                units[f.name] = f.metadata[b"unit"].decode()
    df = pd.concat([t.to_pandas() for t in tables], ignore_index=True)
    df.attrs["units"] = units
    return df


def stored_keys(store: Path) -> set:
    import pyarrow.parquet as pq

    if not store.is_dir():
        return set()
    keys = set()
    for p in store.glob("part-*.parquet"):
        keys.update(pq.read_table(p, columns=["key"]).column("key").to_pylist())
    return keys


def _write_part(store: Path, records: List[dict], parameters: List[Parameter], columns: List[str],
                units: Dict[str, Optional[str]]) -> None:
    """One Parquet file per flush, renamed into place so a reader never sees half a file.
    A parameter's column has the type of its values (:func:`_arrow_type`); a column with a
    unit carries it in its field metadata (``unit``), where :func:`stored` reads it back."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    def column(name, type_):
        u = units.get(name)
        return pa.field(name, type_, metadata={"unit": u} if u else None)

    store.mkdir(parents=True, exist_ok=True)
    schema = pa.schema(
        [("index", pa.int64()), ("key", pa.string())]
        + [column(p.path, _arrow_type(p.values or [])) for p in parameters]
        + [column(c, pa.float64()) for c in columns]
        + [("error", pa.string())]
    )
    table = pa.Table.from_pylist(records, schema=schema)
    name = f"part-{time.strftime('%Y%m%dT%H%M%S')}-{uuid.uuid4().hex[:8]}.parquet"
    tmp = store / f".{name}.partial"
    pq.write_table(table, tmp)
    os.replace(tmp, store / name)


# --------------------------------------------------------------------------------------
# Running a study


@dataclass
class Summary:
    total: int
    already: int
    computed: int
    failed: int
    seconds: float
    errors: List[str]
    # Time the workers spent in the points' solves (the rest of `seconds` × workers is the
    # study machinery, start-up and idle workers).
    task_seconds: float = 0.0

    def text(self, study: Study) -> str:
        lines = [
            f"study {study.path.name}: {self.total} points, {self.already} already stored, "
            f"{self.computed} computed in {self.seconds:.1f} s"
            + (f" ({self.computed / self.seconds:.1f} points/s)" if self.seconds > 0 and self.computed else ""),
            f"  failed: {self.failed}" + "".join(f"\n    {e}" for e in self.errors),
        ]
        df = results(study)
        if len(df):
            ok = df[df["error"].isna()]
            for c in study.result_columns():
                v = ok[c].to_numpy()
                if len(v):
                    lines.append(f"  {c:<28} min {v.min():.6g}  median {np.median(v):.6g}  max {v.max():.6g}")
        lines.append(f"  results → {study.store}")
        return "\n".join(lines)


class _Progress:
    """A one-line progress bar on stderr, redrawn at most every 0.2 s."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled, self.start, self.last = total, enabled, time.perf_counter(), 0.0

    def update(self, done: int, failed: int, final: bool = False) -> None:
        now = time.perf_counter()
        if not self.enabled or (not final and now - self.last < 0.2):
            return
        self.last = now
        rate = done / (now - self.start) if now > self.start else 0.0
        eta = (self.total - done) / rate if rate > 0 else float("inf")
        width = 30
        fill = int(width * done / self.total) if self.total else width
        sys.stderr.write(
            f"\r[{'#' * fill}{'.' * (width - fill)}] {done}/{self.total} points, "
            f"{rate:.1f}/s, ETA {eta:.0f} s, {failed} failed "
        )
        if final:
            sys.stderr.write("\n")
        sys.stderr.flush()


# Aimed-at solve time of one task, s (see `run`). Each task costs the client and the
# scheduler about 5 ms of CPU (measured 2026-11-30), taken from the workers on a machine with
# as many workers as cores: at 0.25 s the client and a separate scheduler took 2.0-2.4 ms per
# 10 ms point, at 1 s 1.2-1.3 ms. A task lost with its worker is computed again, so this is
# also the most solving a killed worker costs per task.
TASK_SECONDS = 1.0


# Dask's servers wake every 20 ms to measure their event loop's latency (a warning when it
# blocks for more than 3 s) and every 500 ms to sample the system for the dashboard: an idle
# 4-worker LocalCluster takes 15 % of one core (measured 2026-11-30), time taken from the solves
# on a machine with as many workers as cores. At 1 s and 2 s it takes 3 %; the latency warning
# still fires, the dashboard's graphs are coarser. docs/python.md "Scale-out".
QUIET_TICKS = {
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
}


def local_cluster(workers: Optional[int] = None, dashboard: Optional[str] = None):
    """The default cluster: ``workers`` single-threaded worker processes (default: one per
    core; the solves release the GIL, but processes also isolate a crashing solve). Dask's
    statistical profiler is off in them: it samples every worker thread every 10 ms, a cost
    paid on every point. ``dashboard`` is the address of Dask's dashboard (``":8787"``;
    ``":0"`` a free port); off by default, and it needs bokeh."""
    import dask
    from distributed import LocalCluster

    if dashboard is not None:
        try:
            import bokeh  # noqa: F401  (distributed serves its dashboard with it)
        except ImportError:
            raise StudyError(f"dashboard = {dashboard!r}: Dask's dashboard needs bokeh "
                             "(pip install 'bokeh>=3.1')") from None

    # glibc gives each thread that allocates its own arena, and the solves run in the worker's
    # task thread: measured 3-8 % slower than the same solves in a main thread, 1-2 % with one
    # arena (the workers have one task thread, so one arena costs no contention). Dask's
    # MALLOC_TRIM_THRESHOLD_ would also turn off glibc's dynamic mmap threshold, so every
    # output array of a solve would be a fresh mmap with its page faults. docs/python.md.
    _refuse_unguarded_script()
    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}))
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    environ["MALLOC_ARENA_MAX"] = 1
    # The worker processes ignore SIGINT: Ctrl-C in a terminal reaches the whole process
    # group, and each worker would print its own traceback; the study's process handles it
    # (stores what arrived) and closes the cluster. A SIGINT ignored at spawn stays ignored
    # in the new interpreters (CPython installs its handler only over the default one).
    import signal

    interactive = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if interactive else None
    try:
        with dask.config.set({"distributed.worker.profile.enabled": False,
                              "distributed.nanny.pre-spawn-environ": environ, **QUIET_TICKS}):
            return LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1,
                                processes=True, dashboard_address=dashboard)
    finally:
        if interactive:
            signal.signal(signal.SIGINT, previous)


def _refuse_unguarded_script() -> None:
    """Worker processes start by importing the script's ``__main__`` module again; a script
    that starts a study at its top level, outside ``if __name__ == "__main__":``, would start
    it again in every worker (multiprocessing's "safe importing of main module"), which ends in
    pages of errors. Refused here with one message, found from the script's source."""
    import ast
    import inspect

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None:  # an interactive session or a notebook: nothing is imported again
        return
    line = None
    for info in inspect.stack(context=0):
        f = info.frame
        if f.f_code.co_name == "<module>" and f.f_globals.get("__name__") in ("__main__", "__mp_main__"):
            line = info.lineno
    if line is None:
        return
    try:
        tree = ast.parse(Path(path).read_text(), filename=path)
    except (OSError, SyntaxError, ValueError):
        return

    def guarded(node) -> bool:
        t = node.test
        return (isinstance(t, ast.Compare) and isinstance(t.left, ast.Name) and t.left.id == "__name__"
                and len(t.comparators) == 1 and isinstance(t.comparators[0], ast.Constant)
                and t.comparators[0].value == "__main__")

    for node in tree.body:
        if isinstance(node, ast.If) and guarded(node) and node.lineno <= line <= (node.end_lineno or node.lineno):
            return
    raise StudyError(
        f"{path}, line {line}: a study with its own worker processes must be started under "
        "`if __name__ == \"__main__\":` (each worker imports the script again and would start "
        "the study anew); or pass client= for a cluster started elsewhere")


def run(
    study,
    client=None,
    scheduler: Optional[str] = None,
    workers: Optional[int] = None,
    progress: bool = True,
    on_result: Optional[Callable[[dict], None]] = None,
    flush_seconds: float = 1.0,
    dashboard: Optional[str] = None,
) -> Summary:
    """Runs the points of ``study`` (a path or :class:`Study`) that are not stored yet.

    The cluster is ``client`` if given, else the scheduler at ``scheduler``, else a new
    core) and, with ``dashboard`` (an address, ``":8787"``), Dask's dashboard. The
    dashboard's address is printed on stderr when the study starts its cluster with one, or
    connects to ``scheduler``.
    ``on_result`` is called with every record as it arrives. Ctrl-C stops the study after
    storing what has arrived; running it again continues it."""
    from distributed import Client, as_completed

    study = study if isinstance(study, Study) else load(study)
    points = study.points()
    keys = [study.key(p) for p in points]
    if len(set(keys)) != len(keys):
        raise StudyError(f"{study.path}: the study draws the same point twice")
    already = stored_keys(study.store) & set(keys)
    todo = [(i, k, p) for i, (k, p) in enumerate(zip(keys, points)) if k not in already]
    names = [p.path for p in study.parameters]
    columns = study.result_columns()
    units = study.units()

    if not todo:
        return Summary(len(points), len(already), 0, 0, 0.0, [])
    own = None
    if client is None:
        if scheduler is not None:
            client = own = Client(scheduler)
        else:
            client = own = Client(local_cluster(workers, dashboard))
    # Dask's HTTP server answers on the dashboard's port with or without the dashboard, so
    # the address is printed where one is known to be there: a LocalCluster started with it,
    # or a scheduler started by `dask scheduler` (which serves it whenever bokeh is there).
    if (own and dashboard is not None) or scheduler is not None:
        print(f"Dask dashboard: {client.dashboard_link}", file=sys.stderr, flush=True)
    start = time.perf_counter()
    computed = failed = 0
    task_seconds = 0.0
    errors: List[str] = []
    buffer: List[dict] = []
    last_flush = time.perf_counter()
    bar = _Progress(len(todo), progress)
    futures = []
    interrupt = _Interrupt()
    try:
        slots = max(1, sum(client.nthreads().values()))
        # Points per task: few at first (about 16 tasks per worker thread, at most 8 points),
        # then sized from the measured solve time so a task takes about TASK_SECONDS (the
        # per-task cost of Dask, a few milliseconds, is then shared by many points), but
        # never so large that fewer than 4 tasks per worker thread remain (the last tasks
        # must end together, or one worker idles through the tail).
        size = study.chunk or max(1, min(8, len(todo) // (16 * slots)))
        next_point = 0

        def next_batch():
            nonlocal next_point
            remaining = len(todo) - next_point
            if remaining <= 0:
                return None
            n = min(size, remaining) if study.chunk else max(1, min(size, remaining // (4 * slots)))
            batch = todo[next_point:next_point + n]
            next_point += n
            return batch

        submit = functools.partial(
            client.submit, run_chunk, study.scene_text, str(study.scene_path), study.analysis,
            study.results, columns, pure=False, retries=2,
        )
        batch_of = {}

        def submit_next():
            batch = next_batch()
            if batch is not None:
                futures.append(submit(batch, study.outputs or None))
                batch_of[futures[-1].key] = batch
                return futures[-1]
            return None

        # A window of tasks in flight (not all at once): the scheduler stays small for 1e6
        # points, and an interrupted run has little to cancel.
        for _ in range(4 * slots):
            submit_next()
        done_iter = as_completed(list(futures))
        for future in done_iter:
            batch = batch_of.pop(future.key)
            try:
                records, seconds = future.result()
                interrupt.check()
                task_seconds += seconds
                if not study.chunk and seconds > 0:
                    size = max(1, min(1024, int(TASK_SECONDS * len(batch) / seconds)))
            except Exception as e:  # noqa: BLE001
                # The task itself failed: its points killed every worker that ran them
                # (Dask gives up after `distributed.scheduler.allowed-failures` deaths).
                # They are stored as failed rather than stopping the study.
                records = [_failed(i, k, p, columns, f"{type(e).__name__}: {e}") for i, k, p in batch]
            f = submit_next()
            if f is not None:
                done_iter.add(f)
            for r in records:
                computed += 1
                arrays = r.pop(ARRAYS, None)
                if arrays is not None and r["error"] is None:
                    # Before the row reaches the Parquet store: a row stored there is never
                    # computed again, so its arrays must already be in.
                    _write_arrays(study, r["index"], r["key"], arrays, len(points))
                if r["error"] is not None:
                    failed += 1
                    if len(errors) < 5:  # the summary shows the first few; all are stored
                        errors.append(f"point {r['index']} {({n: r[n] for n in names})}: {r['error']}")
                buffer.append(r)
                if on_result is not None:
                    on_result(r)
            if time.perf_counter() - last_flush >= flush_seconds:
                _write_part(study.store, buffer, study.parameters, columns, units)
                buffer, last_flush = [], time.perf_counter()
            bar.update(computed, failed)
    except KeyboardInterrupt:
        # Cancelling the tasks in flight and closing the cluster makes Dask's event loop log
        # its own tracebacks (cancelled comms, a nanny closing its worker): an interrupt is
        # told in one line by the caller, so Dask is quiet from here on.
        _quiet_dask()
        try:
            client.run(_quiet_dask, wait=True)  # the workers log the cancelled tasks too
        except Exception:  # noqa: BLE001 -- a worker gone already has nothing to log
            pass
        raise
    finally:
        interrupt.restore()
        if buffer:
            _write_part(study.store, buffer, study.parameters, columns, units)
        bar.update(computed, failed, final=True)
        for f in futures:
            f.cancel()
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None and scheduler is None:
                cluster.close()
    return Summary(len(points), len(already), computed, failed, time.perf_counter() - start, errors,
                   task_seconds)


class _Interrupt:
    """Ctrl-C during a study, raised where it cannot break Dask: inside Dask's ``sync`` (a
    blocking call into the client's event loop) a KeyboardInterrupt makes the loop log a
    traceback of its own (distributed's cancel callback), so there the interrupt is held
    until the call returns and :meth:`check` raises it; anywhere else it is raised at once.
    Installed only in the main thread (the only one signals reach)."""

    def __init__(self):
        import signal

        self.pending = False
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, self._handler)

    def _handler(self, signum, frame):
        sync = os.path.join("distributed", "utils.py")
        f = frame
        while f is not None:
            if f.f_code.co_name == "sync" and f.f_code.co_filename.endswith(sync):
                self.pending = True
                return
            f = f.f_back
        raise KeyboardInterrupt

    def check(self) -> None:
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt

    def restore(self) -> None:
        import signal

        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
            self.previous = None


def _quiet_dask() -> None:
    """Dask's, tornado's and asyncio's loggers keep only critical messages."""
    import logging

    for name in ("distributed", "tornado", "asyncio", "bokeh"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def arrays_store(study) -> Path:
    """The Zarr store of the study's per-point arrays (``analysis.arrays``, user outputs
    that return arrays): ``<store>`` with the suffix ``.zarr``."""
    return study.store.with_suffix(".zarr")


def _write_arrays(study, index: int, key: str, arrays: Dict[str, np.ndarray], n: int) -> None:
    """Writes one point's (one-dimensional) arrays as row ``index`` of one Zarr array per
    name, shape ``(points, longest)``: a point's array fills the start of its row, NaN the
    rest, and the array grows when a longer one arrives, so the store is the same whatever
    the order the points finish in. The point's key and each array's length are stored
    beside them."""
    import zarr

    path = arrays_store(study)
    root = zarr.open_group(str(path), mode="a", zarr_format=2)
    if "key" in root and root["key"].shape != (n,):
        # Arrays of another version of the study (other points): their rows mean nothing now.
        root = zarr.open_group(str(path), mode="w", zarr_format=2)
    if "key" not in root:
        root.create_array("key", shape=(n,), dtype=str, fill_value="")
    for name, a in arrays.items():
        if name not in root:
            arr = root.create_array(name, shape=(n, a.size), chunks=(1, max(1, a.size)),
                                    dtype="f8", fill_value=np.nan)
            unit = study.output_units.get(name) if name in study.outputs else \
                geardyn._geardyn.column_unit(name) or _array_unit(name)
            if unit:
                arr.attrs["units"] = unit
            root.create_array(f"{name}.length", shape=(n,), dtype="i8", fill_value=-1)
        arr = root[name]
        if a.size > arr.shape[1]:
            arr.resize((n, a.size))
        row = np.full(arr.shape[1], np.nan)
        row[:a.size] = a
        arr[index] = row
        root[f"{name}.length"][index] = a.size
    root["key"][index] = key


def _array_unit(name: str) -> Optional[str]:
    """Units written in a spectrum column's name (``<signal>_amplitude_m``, ``frequency_Hz``)."""
    if name == "frequency_Hz":
        return "Hz"
    if "_amplitude_" in name:
        return name.rsplit("_amplitude_", 1)[1]
    if name.endswith("_phase_rad"):
        return "rad"
    return None


def _stored_arrays(study, keys: List[str]) -> Dict[str, tuple]:
    """The per-point arrays stored for the points with ``keys`` (in point order): name ->
    (values with NaN rows for points not stored, units)."""
    path = arrays_store(study)
    if not path.exists():
        return {}
    import zarr

    root = zarr.open_group(str(path), mode="r", zarr_format=2)
    if "key" not in root or root["key"].shape != (len(keys),):
        return {}
    valid = np.asarray(root["key"][:]) == np.asarray(keys)
    out = {}
    for name in root.array_keys():
        if name == "key" or name.endswith(".length"):
            continue
        values = np.asarray(root[name][:], dtype=float)
        values[~valid] = np.nan
        out[name] = (values, root[name].attrs.get("units"))
    return out


def results(study):
    """The stored results of the study's points, in point order (a pandas DataFrame). Rows
    that an earlier version of the study left in the store (another base scene, analysis or
    point set: other keys) are not among them."""
    study = study if isinstance(study, Study) else load(study)
    df = stored(study.store)
    if not len(df):
        return df
    units = df.attrs["units"]
    keys = {study.key(p) for p in study.points()}
    df = df[df["key"].isin(keys)]
    df = df.sort_values("index").reset_index(drop=True)
    df.attrs["units"] = units
    return df


def to_xarray(study):
    """The study's stored results as an xarray Dataset, units in each variable's
    ``attrs["units"]`` (from the store), a description in ``attrs["long_name"]``.

    A grid's axes are its dimensions (the first path of each `[[parameter]]`; a linked path
    is a coordinate along its axis), so a 2-D grid is a 2-D array per result; a point not
    stored (yet) is NaN there. Latin hypercube and Monte Carlo points lie along ``point``,
    their parameter values coordinates on it. ``error`` holds each failed point's message
    ("" where it succeeded)."""
    import xarray as xr

    study = study if isinstance(study, Study) else load(study)
    df = results(study)
    units = df.attrs.get("units", {}) if len(df) else study.units()
    columns = study.result_columns()
    described = {**RESULTS[study.kind]}

    def attrs(name):
        a = {}
        if units.get(name):
            a["units"] = units[name]
        r = name.rsplit(".", 1)[-1]
        if r in described and name not in study.outputs:
            a["long_name"] = described[r].rsplit(", ", 1)[0]
        return a

    points = study.points()
    if study.method == "grid":
        axes = [[p for p in study.parameters if p.group == g] for g in study.groups()]
        dims = [axis[0].path for axis in axes]
        shape = tuple(len(axis[0].values) for axis in axes)
        coords = {}
        for d, axis in zip(dims, axes):
            for p in axis:
                coords[p.path] = (d, np.asarray(p.values), attrs(p.path))
        # Grid points are listed in row-major order over the axes (itertools.product).
        at = {study.key(p): i for i, p in enumerate(points)}
        flat = np.array([at[k] for k in df["key"]], dtype=np.int64) if len(df) else np.zeros(0, np.int64)
        data = {}
        for c in columns:
            values = np.full(math.prod(shape), np.nan)
            if len(df):
                values[flat] = df[c].to_numpy(dtype=float)
            data[c] = (dims, values.reshape(shape), attrs(c))
        errors = np.full(math.prod(shape), "", dtype=object)
        if len(df):
            errors[flat] = df["error"].fillna("").to_numpy(dtype=object)
        data["error"] = (dims, errors.reshape(shape))
        _add_arrays(data, study, points, dims, shape)
        return xr.Dataset(data, coords=coords, attrs={"study": str(study.path), "analysis": study.kind})
    n = len(points)
    coords = {p.path: ("point", np.array([pt[p.path] for pt in points]), attrs(p.path))
              for p in study.parameters}
    coords["point"] = ("point", np.arange(n))
    data = {}
    index = df["index"].to_numpy(dtype=np.int64) if len(df) else np.zeros(0, np.int64)
    for c in columns:
        values = np.full(n, np.nan)
        if len(df):
            values[index] = df[c].to_numpy(dtype=float)
        data[c] = ("point", values, attrs(c))
    errors = np.full(n, "", dtype=object)
    if len(df):
        errors[index] = df["error"].fillna("").to_numpy(dtype=object)
    data["error"] = ("point", errors)
    _add_arrays(data, study, points, ["point"], (n,))
    return xr.Dataset(data, coords=coords, attrs={"study": str(study.path), "analysis": study.kind})


def _add_arrays(data: dict, study, points, dims: List[str], shape: tuple) -> None:
    """The per-point arrays as variables over the study's dimensions and their own axis
    ``<name>_sample`` (as long as the longest; a shorter array is NaN after its end), in
    place of a user output's empty scalar column."""
    for name, (values, unit) in _stored_arrays(study, [study.key(p) for p in points]).items():
        data[name] = ([*dims, f"{name}_sample"], values.reshape(*shape, values.shape[1]),
                      {"units": unit} if unit else {})


def to_zarr(study, path) -> Path:
    """Writes :func:`to_xarray`'s Dataset to a Zarr store at ``path`` (replacing one there);
    ``xarray.open_zarr(path)`` reads it back with its units. Needs ``zarr``. The store is
    Zarr format 2 with consolidated metadata: every Zarr reader takes it, where format 3
    has no specification yet for variable-length strings (the ``error`` messages) or for
    consolidated metadata (zarr-python 3.1 warns of both)."""
    path = Path(path)
    to_xarray(study).to_zarr(path, mode="w", zarr_format=2)
    return path


# --------------------------------------------------------------------------------------
# Plot


def plot(study, out) -> Path:
    """A response surface over the varied parameters (grid: a curve for one parameter, a
    filled contour for two) or a histogram per result (Latin hypercube, Monte Carlo)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    study = study if isinstance(study, Study) else load(study)
    df = results(study)
    if not len(df):
        raise StudyError(f"{study.store}: no results to plot yet")
    units = df.attrs.get("units", {})

    def label(name):
        from .plotting import _label

        return _label(name, units.get(name))

    ok = df[df["error"].isna()]
    columns = study.result_columns()
    names = study.axes()
    fig, axes = plt.subplots(1, len(columns), figsize=(4.5 * len(columns), 3.8), squeeze=False)
    for ax, c in zip(axes[0], columns):
        if study.method != "grid":
            ax.hist(ok[c], bins=max(10, int(np.sqrt(len(ok)))), color="#2471a3")
            ax.set_xlabel(label(c))
            ax.set_ylabel("points")
        elif len(names) == 1:
            ax.plot(ok[names[0]], ok[c], "o-", color="#c0392b")
            ax.set_xlabel(label(names[0]))
            ax.set_ylabel(label(c))
        elif len(names) == 2:
            grid = ok.pivot_table(index=names[1], columns=names[0], values=c)
            cs = ax.contourf(grid.columns, grid.index, grid.to_numpy(), levels=20)
            fig.colorbar(cs, ax=ax, label=label(c))
            ax.set_xlabel(label(names[0]))
            ax.set_ylabel(label(names[1]))
        else:
            raise StudyError(f"plot: a response surface takes 1 or 2 varied parameters, this grid has {len(names)}")
        ax.set_title(c)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


# --------------------------------------------------------------------------------------
# Console script


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="geardyn-study", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run the points not stored yet, then print a summary")
    r.add_argument("study", type=Path)
    r.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a LocalCluster)")
    r.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per core)")
    r.add_argument("--no-progress", action="store_true")
    r.add_argument("--plot", type=Path, help="also draw the plot (PNG/SVG/PDF)")
    r.add_argument("--dashboard", nargs="?", const=":8787", metavar="ADDRESS",
                   help="serve Dask's dashboard from the LocalCluster (default address :8787; "
                   "needs bokeh) and print its address")
    p = sub.add_parser("plot", help="response surface (grid) or histograms (lhs, monte_carlo)")
    p.add_argument("study", type=Path)
    p.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    try:
        study = load(args.study)
        if args.command == "run":
            try:
                summary = run(study, scheduler=args.scheduler, workers=args.workers,
                              progress=not args.no_progress, dashboard=args.dashboard)
            except KeyboardInterrupt:
                print("interrupted: the points that arrived are stored; run again to continue",
                      file=sys.stderr)
                return 130
            print(summary.text(study))
            if args.plot:
                print(f"plot → {plot(study, args.plot)}")
        else:
            print(f"plot → {plot(study, args.out)}")
    except (StudyError, geardyn.GeardynError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
