//! The model part of the FMU's `documentation/index.html` (FMI 2.0.x §2.3), condensed from
//! `docs/train.md` (the specification); the adapter adds the
//! co-simulation behaviour ([`crate::fmu::Adapter`]), the packager the variable table.

pub(super) const DOCUMENTATION: &str = r#"<h2>Model</h2>
<p>A drivetrain of gears (rotation, optional bearing translations), shafts and meshes
(Liu 2007, Ch. 2&ndash;4), in elastic coordinates &xi; after the rigid-body motion is split off
(<code>q = Q&xi; + R&eta;</code>):</p>
<pre>M xi'' + C xi' + K_b xi + sum_n a_n F_n = F_ext
a_n = Q' d_n,   S_n = a_n' xi                      (mesh deflection of mesh n)
F_n = sum over tooth pairs j in contact of k_j(s) (S_n - e_n(p_n) - g_j(s) + o_j) + c_n (S_n' - e_n')</pre>
<p><code>M</code>, <code>K_b</code>, <code>C</code>: reduced mass, bearing/shaft/ground stiffness and
damping (viscous plus modal damping on the mean-stiffness modes); <code>F_ext</code> from
<code>operating.input_torque</code> on the input gear and <code>operating.load_torque</code> resisting the output gear.
Each mesh has its own phase <code>p_n = phi_n + (f_n/f_1) p_1(0) + f_n t</code>, its mesh frequency
<code>f_n</code> following the input speed by the train's kinematics. Per tooth pair: stiffness over
its engagement window, tip-relief gap <code>g_j</code>, contact flag (drive, separated, back side with
offset <code>o_j = 2b</code>). The DTE output is the rotational part
<code>r_a&theta;_a &minus; r_b&theta;_b</code> of <code>S_n</code>.</p>
<p>Contact changes of every pair are state events; stiffness and gap knots are landed on
exactly. Trains whose segments are linear time-invariant are propagated exactly (matrix
exponential per segment), others with an adaptive Runge&ndash;Kutta pair with dense output.</p>
"#;

/// The documentation's item on the start of a run.
pub(super) const START: &str = r#"The scene's <code>t = 0</code> is the experiment's start time; the initial state is the scene's
(by default the static equilibrium) under the inputs set before initialization ends."#;
