//! The FMU's `documentation/index.html` body for an element (FMI 2.0.x §2.3), condensed from
//! `docs/elements.md`; the packager adds the variable table.

use crate::model::elements::ElementSpec;

const COMMON: &str = r#"<h2>Co-simulation behaviour</h2>
<ul>
<li><code>fmi2DoStep</code> integrates exactly to <code>tc + h</code> (DOP853 at the scene's
tolerances) for any positive <code>h</code>.</li>
<li>Inputs are held constant over a step unless <code>fmi2SetRealInputDerivatives</code> (orders 1
to 3, the vendor annotation <code>InputDerivatives maxOrder="3"</code>) gave derivatives: then the
next step uses the Taylor polynomial <code>u(t) = u + u'&middot;s + u''&middot;s&sup2;/2 +
u'''&middot;s&sup3;/6</code>, <code>s = t &minus; tc</code>, and at its end the input holds the
polynomial's end value with derivatives 0 again (<code>canInterpolateInputs="true"</code>).</li>
<li><code>fmi2GetRealOutputDerivatives</code> answers order 1 for every output
(<code>maxOutputDerivativeOrder="1"</code>): d/dt angle = speed, d/dt speed = acceleration, the
rates of accelerations and torques from the equations with the current input rates.</li>
<li>Sign convention: a flange torque input is the torque applied TO the element. The shaft's
torque outputs are the torques it exerts ON its neighbours, to be connected directly to their
torque inputs.</li>
<li>Parameters are fixed: they can be set before <code>fmi2ExitInitializationMode</code> only.
FMU state get/set and serialization are supported.</li>
</ul>
"#;

/// The model part for an element of this kind, then the co-simulation behaviour.
pub(super) fn html(spec: &ElementSpec) -> String {
    let model = match spec {
        ElementSpec::Inertia(_) => {
            r#"<h2>Inertia</h2><p>One rigid body between flanges a and b (torque causality):</p>
<pre>J w' = T_a + T_b - d w,   theta' = w</pre><p>Both flanges output the same angle, speed and acceleration.</p>"#
        }
        ElementSpec::Shaft(_) => {
            r#"<h2>Torsional shaft</h2><p>A massless spring-damper between flanges a and b (speed causality: inputs angle and speed of each end), stateless:</p>
<pre>tau = k (phi_a - phi_b) + c (w_a - w_b)
flange_a.torque = -tau   (acts on the body at a)
flange_b.torque = +tau   (acts on the body at b)</pre>"#
        }
        ElementSpec::Motor(_) => {
            r#"<h2>Motor</h2><p>A torque source with a rotor (flange torque causality):</p>
<pre>J_m w' = T_e + T_r + T_flange - d_m w,   T_r = sum a cos(o theta + phi)
open loop:  T_e = torque_fraction * T_max(w)
PI:         e = w_ref - w, T_e = clamp(kp e + ki I, -T_max(w), T_max(w)),
            I' = e, except 0 when saturated and e pushes further into saturation</pre>
<p><code>T_max(w)</code> is the full-load curve, linear between its points and constant beyond the ends.</p>"#
        }
        ElementSpec::Load(_) => {
            r#"<h2>Vehicle-like load</h2><p>An inertia with resistance (flange torque causality):</p>
<pre>J_L w' = T_flange - T_0 - c_v w - c_d w|w|</pre>"#
        }
    };
    format!("{model}\n{COMMON}")
}
