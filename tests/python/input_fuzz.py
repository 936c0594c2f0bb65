"""Bad Python inputs for the geardyn module (issue 34, acceptance 4), and the worker that
runs them.

``case(i)`` builds input ``i`` deterministically from its index (a seeded generator per
index), so a worker process and the test agree on every input without passing objects
between processes, and a failure is replayed with ``python tests/python/input_fuzz.py i``.
Every case is invalid by construction (at least one argument is outside what the API takes),
so each must end in a Python exception; none may end the interpreter.

The worker (``python input_fuzz.py --worker``) reads case indices from stdin, one per line,
and answers ``start <i>`` before and ``done <i> <kind> <exception type>`` (or ``RETURNED``)
after each, flushing both: the parent (test_input_fuzz.py) thus knows which case was running
when a worker died.
"""

import ctypes
import math
import os
import pathlib
import random
import sys
import tempfile
import tomllib

import numpy as np

import geardyn
from geardyn import study

REPO = pathlib.Path(__file__).resolve().parents[2]

# Shipped scenes as plain dicts (element scenes included: they are TOML like the others).
SCENE_FILES = sorted(REPO.glob("fmu/*/scene.toml")) + sorted(REPO.glob("tests/scenes/*.toml"))
SCENE_FILES += [p for p in sorted(REPO.glob("examples/**/*.toml")) if p.name != "study_spur.toml"]
STUDY_FILE = REPO / "examples" / "study_spur.toml"
GEARS_FILE = REPO / "fmu" / "geometry_pair" / "gears.toml"

_DICTS = {}


def scene_dict(path):
    if path not in _DICTS:
        _DICTS[path] = tomllib.loads(path.read_text())
    return _DICTS[path]


_EXAMPLE = None


def example():
    """A valid scene to call the analyses on (every call gets an invalid argument)."""
    global _EXAMPLE
    if _EXAMPLE is None:
        _EXAMPLE = geardyn.Scene.example("spur_pair")
    return _EXAMPLE


# --- hostile values -------------------------------------------------------------------------


class ToListSelf:
    """An object whose ``tolist`` returns itself (a cycle through NumPy's protocol)."""

    def tolist(self):
        return self


class ToListRaises:
    def tolist(self):
        raise RuntimeError("tolist failed")


class ToListDeep:
    """``tolist`` returns an object with ``tolist`` ... without end."""

    def tolist(self):
        return ToListDeep()


class BadDict(dict):
    def items(self):
        raise RuntimeError("no items")

    def __iter__(self):
        raise RuntimeError("no iteration")


def deep_dict(depth):
    d = {}
    c = d
    for _ in range(depth):
        c["a"] = {}
        c = c["a"]
    return d


def deep_list(depth):
    outer = []
    c = outer
    for _ in range(depth):
        c.append([])
        c = c[0]
    return outer


def deep_mixed(depth, rng):
    top = {}
    c = top
    for _ in range(depth):
        nxt = {} if rng.random() < 0.5 else []
        if isinstance(c, dict):
            c["k"] = nxt
        else:
            c.append(nxt)
        c = nxt
    return top


def cycle(rng):
    """A container that reaches itself."""
    kind = rng.randrange(5)
    if kind == 0:
        d = {}
        d["a"] = d
        return d
    if kind == 1:
        lst = []
        lst.append(lst)
        return {"a": lst}
    if kind == 2:
        d1, d2 = {}, {}
        d1["x"] = d2
        d2["y"] = d1
        return d1
    if kind == 3:
        lst = [1.0]
        t = (lst,)
        lst.append(t)
        return {"t": t}
    d = {"gear": [{"name": "p"}]}
    d["gear"][0]["self"] = d["gear"]
    return d


# Values no scene field takes: types TOML has no form for, integers beyond 64 bits, deep
# or cyclic structures, objects whose conversion protocols fail.
def bad_value(rng):
    k = rng.randrange(23)
    return [
        lambda: b"bytes",
        lambda: bytearray(b"x"),
        lambda: {1, 2},
        lambda: frozenset(),
        lambda: 1 + 2j,
        lambda: None,
        lambda: object(),
        lambda: (lambda: 0),
        lambda: Ellipsis,
        lambda: 2**64,
        lambda: -(2**70),
        lambda: 10**400,
        lambda: ToListSelf(),
        lambda: ToListRaises(),
        lambda: ToListDeep(),
        lambda: BadDict(a=1),
        lambda: deep_dict(rng.choice([65, 1000, 15_000])),
        lambda: deep_list(rng.choice([65, 1000, 100_000])),
        lambda: deep_mixed(rng.choice([100, 5000]), rng),
        lambda: cycle(rng),
        lambda: "\ud800",  # a lone surrogate: not UTF-8
        lambda: np.array([1 + 1j]),
        lambda: np.array([object()], dtype=object),
    ][k]()


def paths_of(v, prefix=()):
    out = []
    if isinstance(v, dict):
        for k, x in v.items():
            out.append(prefix + (k,))
            out.extend(paths_of(x, prefix + (k,)))
    elif isinstance(v, list):
        for i, x in enumerate(v):
            out.append(prefix + (i,))
            out.extend(paths_of(x, prefix + (i,)))
    return out


def set_at(doc, path, value):
    c = doc
    for p in path[:-1]:
        c = c[p]
    c[path[-1]] = value


def copy(v):
    if isinstance(v, dict):
        return {k: copy(x) for k, x in v.items()}
    if isinstance(v, list):
        return [copy(x) for x in v]
    return v


# --- the cases --------------------------------------------------------------------------------


def case_from_dict(rng):
    """A shipped scene with a hostile value, or a hostile key, somewhere in it."""
    doc = copy(scene_dict(rng.choice(SCENE_FILES)))
    paths = paths_of(doc)
    path = rng.choice(paths)
    if rng.random() < 0.8:
        set_at(doc, path, bad_value(rng))
    else:
        parent = doc
        for p in path[:-1]:
            parent = parent[p]
        if not isinstance(parent, dict):
            parent = doc
        parent[rng.choice([1, 2.5, None, ("t",), b"k", "\ud800"])] = 1.0
    return lambda: geardyn.Scene.from_dict(doc)


def case_structure(rng):
    """A whole input that is no scene: deep, cyclic or not a dict at all."""
    k = rng.randrange(6)
    if k == 0:
        d = deep_dict(rng.choice([15_000, 30_000, 100_000]))
    elif k == 1:
        d = {"a": deep_list(rng.choice([15_000, 100_000]))}
    elif k == 2:
        d = cycle(rng)
    elif k == 3:
        d = deep_mixed(rng.choice([20_000, 50_000]), rng)
    elif k == 4:
        d = rng.choice([[], None, "scene", 3, BadDict(a=1)])
    else:
        d = {"gear": [bad_value(rng) for _ in range(3)]}
    return lambda: geardyn.Scene.from_dict(d)


def case_from_toml(rng):
    """TOML text no scene is: deep nesting, bytes, non-finite literals, broken syntax."""
    n = rng.choice([1000, 20_000, 100_000])
    k = rng.randrange(8)
    if k == 0:
        text = "a = " + "[" * n + "]" * n
    elif k == 1:
        text = "a = " + "{b = " * n + "1" + "}" * n
    elif k == 2:
        text = "a" + ".a" * n + " = 1"
    elif k == 3:
        text = "[" + ".".join(["t"] * n) + "]\nx = 1"
    elif k == 4:
        # Broken syntax at the start of a line (inside a comment or a string it would be text).
        lines = rng.choice(SCENE_FILES).read_text().split("\n")
        at = rng.randrange(len(lines))
        lines[at] = rng.choice(["\x00", "[[", "= =", "\"", "]]]", "\ud800"]) + lines[at]
        text = "\n".join(lines)
    elif k == 5:
        text = bytes(rng.randrange(256) for _ in range(rng.choice([10, 1000]))).decode("latin-1") + "\x00"
    elif k == 6:
        text = f"name = \"x\"\n[solver]\nstop_time = {rng.choice(['1e999', 'inf', 'nan', '-0'])}"
    else:
        text = "[[gear]]\n" * n
    return lambda: geardyn.Scene.from_toml(text)


# Counts the API refuses: negative, zero where one is needed, beyond the integer types,
# not integers at all.
BAD_COUNTS = [-1, -(2**31), 2**32, 2**64, 10**30, True, 1.5, "3", float("nan"), [3], object()]


def case_counts(rng):
    s = example()
    bad = rng.choice(BAD_COUNTS)
    k = rng.randrange(9)
    if k == 0:
        return lambda: geardyn.periodic(s, periods=bad)
    if k == 1:
        return lambda: geardyn.periodic(s, warmup=bad if bad != 0 else -1)
    if k == 2:
        return lambda: geardyn.sweep(s, "300:400:3", max_periods=bad)
    if k == 3:
        return lambda: geardyn.hb(s, "300:400", harmonics=bad)
    if k == 4:
        return lambda: geardyn.hb(s, "300:400", subharmonic=bad)
    if k == 5:
        return lambda: geardyn.stiffness(GEARS_FILE, 100.0, harmonics=bad)
    # (2**32 is a valid row count: it takes a 64-bit count.)
    bad64 = bad if bad != 2**32 else 2**64
    if k == 6:
        return lambda: geardyn.simulate(s, max_rows=bad64)
    if k == 7:
        # Every analysis takes work_budget= and checks it before any work.
        budget = rng.choice([-1.0, 0.0, 0.5, float("nan"), float("inf"), "x"])
        return rng.choice(
            [
                lambda: geardyn.simulate(s, work_budget=budget),
                lambda: geardyn.periodic(s, work_budget=budget),
                lambda: geardyn.sweep(s, "300:400:3", work_budget=budget),
                lambda: geardyn.hb(s, "300:400", work_budget=budget),
            ]
        )
    return lambda: geardyn.simulate(s, max_periods=rng.choice([-1.0, 0.0, float("nan"), "x"]))


# Counts that are integers but beyond what the analyses take (checked before allocating).
BIG_COUNTS = [10**9, 4_000_000_000, 2**31 - 1]


def case_big_counts(rng):
    s = example()
    big = rng.choice(BIG_COUNTS)
    k = rng.randrange(6)
    if k == 0:
        return lambda: geardyn.periodic(s, periods=big)
    if k == 1:
        return lambda: geardyn.sweep(s, f"300:400:{rng.choice([10**11, 10**6, 2**64])}")
    if k == 2:
        return lambda: geardyn.sweep(s, "300:400:181", max_periods=big)
    if k == 3:
        return lambda: geardyn.hb(s, "300:400", harmonics=big)
    if k == 4:
        return lambda: geardyn.hb(s, "300:400", subharmonic=big)
    t = s.copy()
    t["solver.output_interval"] = rng.choice([1e-12, 1e-15, 5e-324])
    return lambda: geardyn.simulate(t)


# Speed texts no option reads.
BAD_SPEEDS = ["", ":", "::", "300:400:1e11", "-1:2:3", "nan:inf:5", "1e999rpm", "300rpm:400rpm:-2",
              "400:300:3", "300:300:3", "x" * 100_000, "300:400:3:4", "0:0", "\x00", "300:4e999:3"]


def case_speeds(rng):
    s = example()
    text = rng.choice(BAD_SPEEDS)
    k = rng.randrange(4)
    if k == 0:
        return lambda: geardyn.sweep(s, text)
    if k == 1:
        return lambda: geardyn.hb(s, text if text.count(":") != 2 else text + ":")
    if k == 2:
        return lambda: geardyn.parse_speed(text + "rpmx")
    return lambda: geardyn.periodic(s, speed=text + "q")


# Scene paths and edits the scene refuses.
BAD_PATHS = ["", ".", "a..b", "gear[99999999999999999999]", "gear[-1]", "[0]", "gear[", "gear]",
             ".".join(["a"] * 10_000), "mesh.stiffness.mean.x", "operating[0]", "\ud800"]


def case_items(rng):
    s = example().copy()
    k = rng.randrange(5)
    path = rng.choice(BAD_PATHS)
    if k == 0:
        return lambda: s[path]
    if k == 1:
        return lambda: s.__setitem__(path, 1.0)
    if k == 2:
        return lambda: s.__setitem__(rng.choice(["mesh.damping_ratio", "name", "solver"]), bad_value(rng))
    if k == 3:
        return lambda: s.update({"operating.pinion_speed": bad_value(rng)})
    return lambda: s.update(rng.choice([[("a", 1)], None, {1: 2}, BadDict(a=1)]))


def case_study(rng):
    """A study spec with a count or field no study takes."""
    doc = tomllib.loads(STUDY_FILE.read_text())
    doc["scene"] = str(REPO / "fmu" / "spur_pair")
    doc["store"] = str(pathlib.Path(tempfile.gettempdir()) / "geardyn_fuzz_store.parquet")
    k = rng.randrange(7)
    if k == 0:
        doc["parameter"][0]["points"] = rng.choice([10**11, 2**63, -3, 0, 1.5, True])
    elif k == 1:
        doc["parameter"][0] = {"path": "operating.pinion_speed", "from": 300.0, "to": 520.0, "points": 10**4}
        doc["parameter"][1] = {"path": "mesh.damping_ratio", "from": 0.01, "to": 0.1, "points": 10**4}
    elif k == 2:
        doc["sampling"] = {"method": "lhs", "samples": rng.choice([10**11, 10**7, -1, 0])}
        doc["seed"] = 1
        doc["parameter"] = [{"path": "operating.pinion_speed", "distribution": "uniform", "low": 300.0, "high": 400.0}]
    elif k == 3:
        doc["chunk"] = rng.choice([-1, 0, 1.5, "x"])
    elif k == 4:
        doc["parameter"][0]["path"] = rng.choice(BAD_PATHS)
    elif k == 5:
        doc["analysis"] = {"kind": "sweep", "speed": rng.choice(BAD_SPEEDS[:9])}
        doc["parameter"] = [{"path": "mesh.damping_ratio", "values": [0.02]}]
    else:
        doc["scene"] = rng.choice(["/nonexistent", "", str(REPO / "fmu" / "emotor")])

    def run():
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "study.toml"
            path.write_text(toml_text(doc))
            study.load(path)

    return run


def toml_text(v, prefix=""):
    """A small TOML writer for the study specs (tomllib reads only)."""
    lines, tables = [], []
    for k, x in v.items():
        if isinstance(x, dict):
            tables.append((k, x))
        else:
            lines.append(f"{k} = {toml_value(x)}")
    out = "\n".join(lines) + "\n"
    for k, x in tables:
        out += f"[{prefix}{k}]\n" + toml_text(x, f"{prefix}{k}.")
    return out


def toml_value(x):
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, (int, float)):
        return repr(x) if math.isfinite(x) else ("nan" if x != x else ("inf" if x > 0 else "-inf"))
    if isinstance(x, str):
        return '"' + x.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(x, list):
        return "[" + ", ".join(toml_value(i) for i in x) + "]"
    if isinstance(x, dict):
        return "{" + ", ".join(f"{k} = {toml_value(i)}" for k, i in x.items()) + "}"
    return '"?"'


KINDS = [
    (case_from_dict, 30),
    (case_structure, 12),
    (case_from_toml, 12),
    (case_counts, 15),
    (case_big_counts, 8),
    (case_speeds, 8),
    (case_items, 8),
    (case_study, 7),
]


def case(i):
    """Input ``i``: its kind and the call that must raise."""
    rng = random.Random(0x34B ^ (i * 0x9E3779B97F4A7C15 & 0xFFFFFFFFFFFFFFFF))
    total = sum(w for _, w in KINDS)
    pick = rng.randrange(total)
    for make, w in KINDS:
        if pick < w:
            return make.__name__, make(rng)
        pick -= w
    raise AssertionError("unreachable")


def worker():
    out = sys.stdout
    for line in sys.stdin:
        i = int(line)
        out.write(f"start {i}\n")
        out.flush()
        kind = "?"
        if os.environ.get("INPUT_FUZZ_SELFTEST_CRASH") == str(i):
            ctypes.string_at(0)  # the harness's self-test: a segfault in input i
        try:
            kind, call = case(i)
            call()
            outcome = "RETURNED"
        except Exception as e:  # every failure is an exception: that is what is checked
            outcome = type(e).__name__
        out.write(f"done {i} {kind} {outcome}\n")
        out.flush()


if __name__ == "__main__":
    if sys.argv[1:] == ["--worker"]:
        worker()
    else:
        for arg in sys.argv[1:]:
            kind, call = case(int(arg))
            print(arg, kind)
            call()
