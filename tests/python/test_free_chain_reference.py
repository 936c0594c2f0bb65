"""The independent free-chain reference (`free_chain_reference.py`: physical coordinates, the
rigid-body mode kept, scipy DOP853 with located contact events) against `geardyn simulate` on
the free compliant chains of issue 37 (`ChainSpec::free`, `docs/chains.md`), from the same
static start: the DTE and deflection of every mesh to 1e-9 of the static deflection, with the
same contact events; and, on the linear law, the exact period map in long double, which
decides between two double-precision integrators (issue 37 acceptance 2: before the fix the
exact propagator was 1.7e-9 δ off on 16 meshes from the first period on).
"""

import numpy as np
import pytest

from conftest import run_geardyn
from free_chain_reference import Chain, dte_and_deflection, free_chain_text


def _simulate(tmp_path, text, periods, samples_per_period, *method):
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    chain = Chain(scene)
    out = tmp_path / "run.csv"
    run_geardyn("simulate", scene, "--out", out, "--stop-time", repr(periods * chain.period),
                "--output-interval", repr(chain.period / samples_per_period), "--quiet",
                "--work-budget", "1e12", *method)
    data = np.genfromtxt(out, delimiter=",", names=True, deletechars="")
    return chain, data


def _columns(data, chain, what):
    return np.array([data[f"mesh{j + 1}.{what}"] for j in range(len(chain.meshes))]).T


@pytest.mark.parametrize("method", [("--method", "exact"),
                                    ("--method", "rk", "--rk-method", "dop853",
                                     "--rtol", "1e-12", "--atol", "1e-15")])
def test_free_chain_with_contact_loss_matches_the_reference(tmp_path, method):
    """4 meshes, 15 µm STE, 20 mesh periods sampled 37 times per period (incommensurate with
    the knots): DTE and deflection within 1e-9 δ, and contact lost where the reference loses
    it (the contact state column against the reference's event list)."""
    chain, data = _simulate(tmp_path, free_chain_text(4, "contact_loss"), 20, 37, *method)
    states, events = chain.run(chain.start_state(), data["time"])
    assert len(events) >= 20, f"the chain must lose contact: {len(events)} events"
    dte, defl = dte_and_deflection(chain, states)
    d = max(np.max(np.abs(_columns(data, chain, "dte") - dte)),
            np.max(np.abs(_columns(data, chain, "deflection") - defl)))
    # The reference's contact state at each sample, from its events.
    state = np.ones((len(data["time"]), len(chain.meshes)))
    for t, j, on in events:
        state[data["time"] > t, j] = 1.0 if on else 0.0
    ours = _columns(data, chain, "contact_state")
    print(f"{method[1]}: {len(events)} reference events; max |Δ| = "
          f"{d / chain.static_deflection:.2e} δ")
    assert np.array_equal(ours, state)
    assert d <= 1e-9 * chain.static_deflection, d / chain.static_deflection


def test_free_16_mesh_chain_linear_law_matches_the_long_double_period_map(tmp_path):
    """16 meshes, linear law, 20 mesh periods: the exact propagator against the reference's
    period map in long double (the rigid mode in its physical coordinates), within 1e-10 δ
    (before issue 37's fix: 1.7e-9 δ)."""
    chain, data = _simulate(tmp_path, free_chain_text(16, "linear"), 20, 1,
                            "--method", "exact")
    states = chain.linear_periods(20)
    dte, defl = dte_and_deflection(chain, states.astype(float))
    d = max(np.max(np.abs(_columns(data, chain, "dte") - dte)),
            np.max(np.abs(_columns(data, chain, "deflection") - defl)))
    print(f"16 meshes, linear: max |Δ| = {d / chain.static_deflection:.2e} δ")
    assert d <= 1e-10 * chain.static_deflection, d / chain.static_deflection
