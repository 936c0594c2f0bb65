"""Issue 34, acceptance 1 (the Python side): each failing case of the second reliability round
is a regression test. Each would have crashed or hung the interpreter; each now raises a Python
exception whose message names the argument (or the scene path) and the value. Each case runs
in a subprocess, so a regression shows as a failed test, not as a dead pytest."""

import subprocess
import sys
import textwrap

import pytest


def outcome(code: str) -> str:
    """Runs `code` (with `geardyn` and `s`, the spur_pair example, defined) in a fresh
    interpreter; the exception it raises, as `<type>: <message>`."""
    program = textwrap.dedent(
        """
        import geardyn
        s = geardyn.Scene.example("spur_pair")
        try:
        {body}
        except Exception as e:
            print(f"{{type(e).__name__}}: {{e}}")
        else:
            print("RETURNED")
        """
    ).format(body=textwrap.indent(textwrap.dedent(code), "    "))
    p = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, f"the interpreter died (status {p.returncode}): {p.stderr[-2000:]}"
    return p.stdout.strip()


@pytest.mark.parametrize(
    "code, expected",
    [
        # A dict nested 15 000 deep, a list 100 000 deep, a dict that contains itself:
        # segfaults of the conversion before.
        (
            """
            d = {}; c = d
            for _ in range(15_000):
                c["a"] = {}; c = c["a"]
            geardyn.Scene.from_dict(d)
            """,
            ["RecursionError", "nested deeper than 64 levels", "'a.a.a"],
        ),
        (
            """
            l = []; c = l
            for _ in range(100_000):
                c.append([]); c = c[0]
            geardyn.Scene.from_dict({"gear": l})
            """,
            ["RecursionError", "'gear[0][0]"],
        ),
        (
            """
            d = {}; d["a"] = d
            geardyn.Scene.from_dict(d)
            """,
            ["ValueError", "'a' contains itself"],
        ),
        (
            """
            t = s.copy()
            d = {}; d["x"] = d
            t["mesh.damping_ratio"] = d
            """,
            ["ValueError", "'x' contains itself"],
        ),
        # 1e11 sweep points killed Python (an 800 GB allocation).
        (
            'geardyn.sweep(s, "300:400:100000000000")',
            ["GeardynError", "points = 100000000000", "100000"],
        ),
        # periods = 10**9 ran for more than 17 minutes.
        (
            "geardyn.periodic(s, periods=10**9)",
            ["GeardynError", "periods = 1000000000", "mesh periods"],
        ),
        # The OverflowError of a negative count did not name the argument.
        ("geardyn.periodic(s, periods=-1)", ["OverflowError", "periods = -1"]),
        ("geardyn.periodic(s, warmup=-1)", ["OverflowError", "warmup = -1"]),
        ('geardyn.sweep(s, "300:400:3", max_periods=-5)', ["OverflowError", "max_periods = -5"]),
        ('geardyn.hb(s, "300:400", harmonics=-2)', ["OverflowError", "harmonics = -2"]),
        ('geardyn.hb(s, "300:400", harmonics=10**12)', ["GeardynError", "harmonics = 1000000000000"]),
        ("geardyn.simulate(s, work_budget=-1)", ["ValueError", "work_budget = -1"]),
        # The work budget: a run beyond it stops, naming the likely cause.
        ("geardyn.simulate(s, work_budget=1e5)", ["GeardynError", "work budget of 1e5", "likely cause"]),
        # Every analysis takes work_budget= (issue 34 item 2), checked like simulate's and
        # the CLI's --work-budget, the error naming the Python argument.
        ("geardyn.periodic(s, work_budget=-1)", ["ValueError", "work_budget = -1"]),
        ('geardyn.sweep(s, "300:400:3", work_budget=float("nan"))', ["ValueError", "work_budget = NaN"]),
        ('geardyn.hb(s, "300:400", work_budget=0)', ["ValueError", "work_budget = 0"]),
        ('geardyn.hb(s, "300:400", work_budget=float("inf"))', ["ValueError", "work_budget = inf"]),
        ('geardyn.sweep(s, "300:400:3", work_budget="x")', ["TypeError", "work_budget"]),
        # A run beyond the budget raises, naming the likely cause; a sweep keeps the point as
        # a row of NaN (as `geardyn sweep` does) and warns with the cause.
        ("geardyn.periodic(s, work_budget=1e3)", ["GeardynError", "work budget of 1e3", "likely cause"]),
        ('geardyn.hb(s, "300:400", work_budget=1e3)', ["GeardynError", "work budget of 1e3", "likely cause"]),
        (
            """
            import warnings
            warnings.simplefilter("error")
            geardyn.sweep(s, "300:400:3", work_budget=1e3)
            """,
            ["RuntimeWarning", "speed 300 rad/s failed", "work budget of 1e3", "likely cause"],
        ),
        # Rows held in memory are bounded before they are allocated.
        (
            """
            t = s.copy(); t["solver.output_interval"] = 1e-10
            geardyn.simulate(t, max_rows=10**12)
            """,
            ["GeardynError", "held in memory"],
        ),
    ],
)
def test_bad_input_raises_naming_it(code, expected):
    got = outcome(code)
    for piece in expected:
        assert piece in got, f"{got!r} lacks {piece!r}"


def test_raised_limits_run():
    """A raised work budget runs the scene that work_budget=1e5 stops above."""
    got = outcome(
        """
        r = geardyn.simulate(s, work_budget=1e9)
        assert len(r.time) == 2001, len(r.time)
        """
    )
    assert got == "RETURNED", got


def test_analyses_run_within_a_raised_budget():
    """The analyses that work_budget=1e3 stops above run with a raised one, and a sweep
    within its budget warns of nothing."""
    got = outcome(
        """
        import warnings
        warnings.simplefilter("error")
        o = geardyn.periodic(s, work_budget=1e10)
        assert o.stability, o
        t = geardyn.sweep(s, "300:400:3", direction="up", work_budget=1e10)
        assert len(t.data) == 3, t.data
        """
    )
    assert got == "RETURNED", got
