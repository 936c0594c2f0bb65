//! The model part of the FMU's `documentation/index.html` (FMI 2.0.x §2.3), condensed from
//! `docs/model.md` (the specification); the adapter adds the
//! co-simulation behaviour ([`crate::fmu::Adapter`]), the packager the variable table.

pub(super) const DOCUMENTATION: &str = r#"<h2>Model</h2>
<p>A single-mesh torsional gear pair in the coordinate of the dynamic transmission error (DTE)
<code>x = r_b1&middot;&theta;1 + r_b2&middot;&theta;2</code> (m, along the line of action; positive
when the drive flanks are pressed together). Eliminating the rigid-body mode gives</p>
<pre>m_e x'' + F(x, x', p) = F_ext
m_e   = 1 / (r_b1^2/I1 + r_b2^2/I2)
F_ext = m_e (r_b1 T1/I1 + r_b2 T2/I2)        (T1 = operating.input_torque, T2 = operating.load_torque)</pre>
<p>Mesh stiffness <code>k(p)</code> and static transmission error <code>e(p)</code> are functions of
the mesh phase <code>p</code> (mesh cycles), which advances with the nominal pinion speed input
&Omega;: <code>dp/dt = z1 &Omega; / (2&pi;)</code>. Mesh deflection <code>&delta; = x &minus; e(p)</code>.</p>
<table border="1">
<tr><th>contact law</th><th>drive side (1)</th><th>separated (0)</th><th>back side (&minus;1)</th></tr>
<tr><td>linear</td><td>F = k&delta; + c_m&delta;' always</td><td>&ndash;</td><td>&ndash;</td></tr>
<tr><td>contact_loss</td><td>&delta; &gt; 0: F = k&delta; + c_m&delta;'</td><td>&delta; &le; 0: F = 0</td><td>&ndash;</td></tr>
<tr><td>backlash (clearance 2b)</td><td>&delta; &gt; 0: F = k&delta; + c_m&delta;'</td><td>&minus;2b &le; &delta; &le; 0: F = 0</td><td>&delta; &lt; &minus;2b: F = k(&delta; + 2b) + c_m&delta;'</td></tr>
</table>
<p>Contact changes are located as state events; stiffness switches are landed on exactly.
Scenes with piecewise-constant stiffness are propagated exactly (matrix exponential per linear
segment), others with an adaptive Runge&ndash;Kutta pair (DOP853/DP5) with dense output.</p>
"#;

/// The documentation's item on the start of a run.
pub(super) const START: &str = r#"The scene's <code>t = 0</code> is the experiment's start time."#;
