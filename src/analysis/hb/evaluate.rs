//! One evaluation of the condensed harmonic-balance residual: every mesh's law at the
//! quadrature nodes (alternating frequency/time), cells split where a contact changes, the
//! Galerkin sums, the Toeplitz/Hankel Jacobian with the boundary terms of the split points,
//! and the frequency derivative for the continuation.

use std::f64::consts::TAU;

use nalgebra::{Complex, DMatrix, DVector};

use super::problem::{cmul, cs, factor, Accumulator, Evaluation, Problem, Want, GAUSS3, PROBE};
use crate::model::{Drivetrain, MeshLaw};
use crate::solve::roots::illinois;

impl<M: Drivetrain> Problem<M> {
    /// `(S, dS/dθ)` of mesh `n` from the basis row.
    #[inline]
    pub(super) fn deflection(&self, s: &DVector<f64>, n: usize, phi: &[f64]) -> (f64, f64) {
        // Over slices (no indexing check per order): the same operations in the same order.
        let coefficients = &s.as_slice()[n * self.len..(n + 1) * self.len];
        let mut x = coefficients[0];
        let mut dx = 0.0;
        let pairs = coefficients[1..]
            .chunks_exact(2)
            .zip(phi[1..].chunks_exact(2));
        for (&w, (ab, row)) in self.order_rates[1..].iter().zip(pairs) {
            let (a, b) = (ab[0], ab[1]);
            let (c, sn) = (row[0], row[1]);
            x += a * c + b * sn;
            dx += w * (b * c - a * sn);
        }
        (x, dx)
    }

    /// Every mesh's law at `θ` for the coefficients `s` (`phi` the basis row at `θ`).
    pub(super) fn laws_at(&self, theta: f64, phi: &[f64], s: &DVector<f64>, out: &mut [MeshLaw]) {
        for (n, law) in out.iter_mut().enumerate() {
            *law = self.law_at(n, theta, self.f, phi, s);
        }
    }

    /// Mesh `n`'s law at `θ` of the HB period `1/f` for the coefficients `s` (`phi` the basis
    /// row at `θ`): from `S_n`, and from the back flanks' own `S̃_n` for a mesh with a back
    /// row ([`Drivetrain::mesh_law_with_back`]).
    #[inline]
    pub(super) fn law_at(
        &self,
        n: usize,
        theta: f64,
        f: f64,
        phi: &[f64],
        s: &DVector<f64>,
    ) -> MeshLaw {
        let (x, dx) = self.deflection(s, n, phi);
        match self.meshes[n].back {
            None => self.model.mesh_law(n, theta / f, x, f * dx),
            Some(c) => {
                let (xb, dxb) = self.deflection(s, c, phi);
                self.model
                    .mesh_law_with_back(n, theta / f, x, f * dx, (xb, f * dxb))
            }
        }
    }

    /// Mesh `n`'s switching functions at `θ` ([`Drivetrain::contact_gaps_with_back`] for a
    /// mesh with a back row, [`Problem::gap_coordinate`] says on which deflection each is).
    pub(super) fn gaps_at(
        &self,
        n: usize,
        theta: f64,
        f: f64,
        phi: &[f64],
        s: &DVector<f64>,
        buf: &mut Vec<(f64, f64)>,
    ) {
        let (x, dx) = self.deflection(s, n, phi);
        match self.meshes[n].back {
            None => self.model.contact_gaps(n, theta / f, x, f * dx, buf),
            Some(c) => {
                let (xb, dxb) = self.deflection(s, c, phi);
                self.model
                    .contact_gaps_with_back(n, theta / f, x, f * dx, (xb, f * dxb), buf)
            }
        }
    }

    /// Adds one quadrature node (weight `w`, basis row `phi`, every mesh's law) to the sums.
    fn accumulate(&self, w: f64, phi: &[f64], laws: &[MeshLaw], want: Want, acc: &mut Accumulator) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX (checked just above).
            unsafe { self.accumulate_avx(w, phi, laws, want, acc) };
            return;
        }
        self.accumulate_sums(w, phi, laws, want, acc);
    }

    /// [`Problem::accumulate_sums`] compiled for AVX: four lanes per instruction instead of
    /// two in its element-wise loops. The same multiplications and additions in the same
    /// order (no fused multiply-add, no reduction), so the sums are bit for bit those of the
    /// baseline build.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn accumulate_avx(
        &self,
        w: f64,
        phi: &[f64],
        laws: &[MeshLaw],
        want: Want,
        acc: &mut Accumulator,
    ) {
        self.accumulate_sums(w, phi, laws, want, acc);
    }

    #[inline(always)]
    fn accumulate_sums(
        &self,
        w: f64,
        phi: &[f64],
        laws: &[MeshLaw],
        want: Want,
        acc: &mut Accumulator,
    ) {
        let mut trig_ready = false;
        if want.samples {
            // One weight per mesh ([`Accumulator::sample_w`]).
            acc.sample_w.extend(std::iter::repeat_n(w, laws.len()));
            acc.sample_force
                .extend((laws.iter().enumerate()).map(|(n, l)| self.total_force(n, l)));
            acc.sample_lost
                .extend(laws.iter().map(|l| l.in_contact == 0));
        }
        for (mesh, law) in self.meshes.iter().zip(laws) {
            for k in 0..mesh.outputs {
                let out = mesh.first + k;
                let fw = w * law.force[k];
                if fw != 0.0 {
                    for (g, p) in acc.gal[out].iter_mut().zip(phi) {
                        *g += fw * p;
                    }
                }
                if want.frequency && law.viscous[k] != 0.0 {
                    let vw = w * law.viscous[k];
                    for (g, p) in acc.visc[out].iter_mut().zip(phi) {
                        *g += vw * p;
                    }
                }
                if !want.jacobian {
                    continue;
                }
                let (ks, kv) = (w * law.stiffness[k], w * law.damping[k]);
                if (ks != 0.0 || kv != 0.0) && !trig_ready {
                    // (cos, sin)(2πdθ) of the sums and differences from the row.
                    for (i, &(_, q, p, plus)) in self.sums.iter().enumerate() {
                        let (cq, sq) = cs(phi, q);
                        let (cp, sp) = cs(phi, p);
                        let (c, s) = if plus {
                            (cq * cp - sq * sp, sq * cp + cq * sp)
                        } else {
                            (cq * cp + sq * sp, sq * cp - cq * sp)
                        };
                        acc.trig[2 * i] = c;
                        acc.trig[2 * i + 1] = s;
                    }
                    trig_ready = true;
                }
                if ks != 0.0 {
                    for (g, c) in acc.kap_s[out].iter_mut().zip(&acc.trig) {
                        *g += ks * c;
                    }
                }
                if kv != 0.0 {
                    for (g, c) in acc.kap_v[out].iter_mut().zip(&acc.trig) {
                        *g += kv * c;
                    }
                }
            }
        }
    }

    /// Gap `q` of mesh `n` and its θ-derivative at `θ`.
    fn gap(
        &self,
        s: &DVector<f64>,
        (n, q): (usize, usize),
        theta: f64,
        phi: &mut [f64],
        buf: &mut Vec<(f64, f64)>,
    ) -> (f64, f64) {
        self.basis_fast(theta, phi);
        self.gaps_at(n, theta, self.f, phi, s, buf);
        buf.get(q).map_or((0.0, 0.0), |g| (g.0, g.1 / self.f))
    }

    /// The root of gap `q` of mesh `n` in `(lo, hi)`, where it changes sign ([`illinois`]).
    pub(super) fn root(
        &self,
        s: &DVector<f64>,
        which: (usize, usize),
        bracket: (f64, f64),
        phi: &mut [f64],
        buf: &mut Vec<(f64, f64)>,
    ) -> f64 {
        illinois(|theta| self.gap(s, which, theta, phi, buf).0, bracket)
    }

    /// A cell in which some contact changes: split at the switching instants, each part
    /// integrated by its own Gauss rule, boundary terms recorded for the Jacobian.
    fn split_cell(&self, c: usize, s: &DVector<f64>, want: Want, acc: &mut Accumulator) {
        let (lo, hi) = self.cells[c];
        let len = self.len;
        let nm = self.meshes.len();
        let mut points = [self.probe(c, 0), 0.0, 0.0, 0.0, self.probe(c, 1)];
        points[1..4].copy_from_slice(&self.nodes[3 * c..3 * c + 3]);
        let mut phi = vec![0.0; len];
        let mut buf = Vec::new();
        let mut cuts: Vec<(f64, usize, usize)> = Vec::new();
        let mut gaps: Vec<Vec<f64>> = vec![Vec::new(); points.len()];
        for n in 0..nm {
            for (k, &theta) in points.iter().enumerate() {
                self.basis_fast(theta, &mut phi);
                self.gaps_at(n, theta, self.f, &phi, s, &mut buf);
                gaps[k].clear();
                gaps[k].extend(buf.iter().map(|g| g.0));
            }
            for k in 0..points.len() - 1 {
                for (q, (a, b)) in gaps[k].iter().zip(&gaps[k + 1]).enumerate() {
                    if (*a > 0.0) != (*b > 0.0) {
                        let bracket = (points[k], points[k + 1]);
                        let root = self.root(s, (n, q), bracket, &mut phi, &mut buf);
                        cuts.push((root, n, q));
                    }
                }
            }
        }
        cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut laws = vec![MeshLaw::default(); nm];
        let mut start = lo;
        for end in cuts.iter().map(|c| c.0).chain(std::iter::once(hi)) {
            let half = 0.5 * (end - start);
            if half > 0.0 {
                for (x, wt) in GAUSS3 {
                    let theta = start + half * (1.0 + x);
                    self.basis_fast(theta, &mut phi);
                    self.laws_at(theta, &phi, s, &mut laws);
                    self.accumulate(half * wt, &phi, &laws, want, acc);
                }
            }
            start = end;
        }
        if !want.jacobian {
            return;
        }
        let eps = PROBE * (hi - lo);
        for &(theta, n, q) in &cuts {
            let mesh = &self.meshes[n];
            let delta_theta = self.gap(s, (n, q), theta, &mut phi, &mut buf).1;
            if delta_theta == 0.0 {
                continue;
            }
            let h = 1e-3 * eps.max(1e-14);
            let mut law_at = |theta: f64| {
                self.basis_fast(theta, &mut phi);
                self.law_at(n, theta, self.f, &phi, s)
            };
            let (left, right) = (law_at(theta - h), law_at(theta + h));
            self.basis_fast(theta, &mut phi);
            let moving = self.gap_coordinate(n, q);
            for k in 0..mesh.outputs {
                // Only the jump counts: remove the continuous part's change over 2h (along
                // the output's own deflection where the root is on the other one).
                let own = self.output_coordinate(n, k);
                let rate = if own == moving {
                    delta_theta
                } else {
                    self.deflection(s, own, &phi).1
                };
                let slope = 0.5 * (right.stiffness[k] + left.stiffness[k]) * rate;
                let jump = right.force[k] - left.force[k] - slope * 2.0 * h;
                if jump.abs() <= 1e-9 * (right.force[k].abs() + left.force[k].abs()) {
                    continue;
                }
                if own == moving {
                    acc.boundary
                        .push((mesh.first + k, jump / delta_theta, phi.clone()));
                } else {
                    acc.cross_boundary.push((
                        mesh.first + k,
                        moving,
                        jump / delta_theta,
                        phi.clone(),
                    ));
                }
            }
        }
    }

    /// Residual and what `want` asks for at coefficients `s` and frequency `f`.
    pub(super) fn evaluate(
        &mut self,
        s: &DVector<f64>,
        f: f64,
        want: Want,
    ) -> Result<Evaluation, String> {
        self.set_frequency(f)?;
        self.receptance(f)?;
        let len = self.len;
        let outs = self.outputs();
        let nm = self.meshes.len();
        let ns = self.sums.len();
        let zeros = |n: usize, on: bool| {
            if on {
                vec![vec![0.0; n]; outs]
            } else {
                Vec::new()
            }
        };
        let fresh = || Accumulator {
            gal: zeros(len, true),
            visc: zeros(len, want.frequency),
            kap_s: zeros(2 * ns, want.jacobian),
            kap_v: zeros(2 * ns, want.jacobian),
            boundary: Vec::new(),
            cross_boundary: Vec::new(),
            sample_w: Vec::new(),
            sample_force: Vec::new(),
            sample_lost: Vec::new(),
            trig: vec![0.0; 2 * ns],
        };
        let mut acc = fresh();
        // A two-frequency train: the sums on the torus (torus.rs), unless it declines (a
        // contact switch it cannot bracket); from then on along the line.
        if let Some(mut torus) = self.torus.take() {
            if torus.accumulate(self, s, want, &mut acc) {
                self.torus = Some(torus);
                return Ok(self.finish(s, f, want, acc));
            }
            acc = fresh();
        }
        // Pass 1: every mesh's law at every node.
        let nodes = self.nodes.len();
        let mut laws = std::mem::take(&mut self.node_laws);
        laws.resize(nodes * nm, MeshLaw::default());
        let mut row = vec![0.0; len];
        for i in 0..nodes {
            let phi = self.node_row(i, &mut row);
            self.laws_at(self.nodes[i], phi, s, &mut laws[i * nm..(i + 1) * nm]);
        }
        // Cells in which a contact pattern changes: between two nodes of a cell, between the
        // last node of a cell and the first of the next (both cells are split; the one without
        // the switch integrates as before), or between a breakpoint and its nearest node (a
        // probe just inside the cell).
        let cells = self.cells.len();
        let mut split = vec![false; cells];
        if self.switching {
            let differ = |i: usize, j: usize| {
                (0..nm).any(|n| laws[i * nm + n].pattern != laws[j * nm + n].pattern)
            };
            let mut probe = vec![MeshLaw::default(); nm];
            for c in 0..cells {
                if differ(3 * c, 3 * c + 1) || differ(3 * c + 1, 3 * c + 2) {
                    split[c] = true;
                }
                if c + 1 < cells && !self.cell_at_break[c + 1] && differ(3 * c + 2, 3 * c + 3) {
                    split[c] = true;
                    split[c + 1] = true;
                }
                for (k, node, at_break) in [
                    (0, 3 * c, self.cell_at_break[c]),
                    (1, 3 * c + 2, c + 1 == cells || self.cell_at_break[c + 1]),
                ] {
                    if at_break && !split[c] {
                        let theta = self.probe(c, k);
                        self.basis_fast(theta, &mut row);
                        self.laws_at(theta, &row, s, &mut probe);
                        if (0..nm).any(|n| probe[n].pattern != laws[node * nm + n].pattern) {
                            split[c] = true;
                        }
                    }
                }
            }
        }
        // Pass 2: the sums.
        for (c, &split) in split.iter().enumerate() {
            if split {
                self.split_cell(c, s, want, &mut acc);
                continue;
            }
            for i in 3 * c..3 * c + 3 {
                let phi = self.node_row(i, &mut row);
                self.accumulate(
                    self.weights[i],
                    phi,
                    &laws[i * nm..(i + 1) * nm],
                    want,
                    &mut acc,
                );
            }
        }
        self.node_laws = laws;
        Ok(self.finish(s, f, want, acc))
    }

    /// The residual, its derivatives and `g` from the quadrature sums `acc`.
    fn finish(&self, s: &DVector<f64>, f: f64, want: Want, acc: Accumulator) -> Evaluation {
        let len = self.len;
        let outs = self.outputs();
        let nm = self.meshes.len();
        // g per output: P[F] minus the moved linear part (exact in the coefficients).
        let mut g: Vec<DVector<f64>> = acc
            .gal
            .iter()
            .map(|gal| DVector::from_fn(len, |r, _| factor(r) * gal[r]))
            .collect();
        let derivative = |x: &[f64]| -> DVector<f64> {
            // d/dθ on the coefficients: (a, b) → 2πj (b, −a).
            let mut d = DVector::zeros(len);
            for (q, &j) in self.orders.iter().enumerate().skip(1) {
                let w = TAU * j as f64;
                d[2 * q - 1] = w * x[2 * q];
                d[2 * q] = -w * x[2 * q - 1];
            }
            d
        };
        let mut ds = Vec::with_capacity(nm);
        for (n, mesh) in self.meshes.iter().enumerate() {
            let sn = s.rows(n * len, len);
            let d = derivative(sn.as_slice());
            g[mesh.first] -= sn * mesh.k_mean + &d * (mesh.c_mean * f);
            ds.push(d);
        }
        let rec = self.receptance.as_ref().expect("computed above");
        let apply = |r: &[DMatrix<Complex<f64>>],
                     n: usize,
                     out: usize,
                     x: &DVector<f64>,
                     y: &mut DVector<f64>| {
            y[0] += r[0][(n, out)].re * x[0];
            for q in 1..self.orders.len() {
                let (a, b) = cmul(r[q][(n, out)], x[2 * q - 1], x[2 * q]);
                y[2 * q - 1] += a;
                y[2 * q] += b;
            }
        };
        let lin_of = |lin: &[DVector<Complex<f64>>], n: usize| {
            let mut y = DVector::zeros(len);
            y[0] = lin[0][n].re;
            for q in 1..self.orders.len() {
                y[2 * q - 1] = lin[q][n].re;
                y[2 * q] = -lin[q][n].im;
            }
            y
        };
        // One block per condensed coordinate (the meshes', then the back flanks').
        let nc = self.coordinates();
        let mut residual = DVector::zeros(nc * len);
        for n in 0..nc {
            let mut y = s.rows(n * len, len).into_owned() - lin_of(&rec.lin, n);
            for (out, go) in g.iter().enumerate() {
                apply(&rec.r, n, out, go, &mut y);
            }
            residual.rows_mut(n * len, len).copy_from(&y);
        }

        let d_frequency = want.frequency.then(|| {
            let mut dg: Vec<DVector<f64>> = acc
                .visc
                .iter()
                .map(|v| DVector::from_fn(len, |r, _| factor(r) * v[r] / f))
                .collect();
            for (n, mesh) in self.meshes.iter().enumerate() {
                dg[mesh.first] -= &ds[n] * mesh.c_mean;
            }
            let mut d = DVector::zeros(nc * len);
            for n in 0..nc {
                let mut y = -lin_of(&rec.dlin, n);
                for out in 0..outs {
                    apply(&rec.dr, n, out, &g[out], &mut y);
                    apply(&rec.r, n, out, &dg[out], &mut y);
                }
                d.rows_mut(n * len, len).copy_from(&y);
            }
            d
        });

        let jacobian = want.jacobian.then(|| {
            let mut jac = DMatrix::<f64>::identity(nc * len, nc * len);
            let mut gs = DMatrix::<f64>::zeros(len, len);
            for (n, mesh) in self.meshes.iter().enumerate() {
                for k in 0..mesh.outputs {
                    let out = mesh.first + k;
                    // ∂g_out/∂s_n: Toeplitz + Hankel of ∂F/∂S, and of ∂F/∂Ṡ times f d/dθ.
                    gs.fill(0.0);
                    self.add_toeplitz(&acc.kap_s[out], 1.0, false, &mut gs);
                    self.add_toeplitz(&acc.kap_v[out], f, true, &mut gs);
                    if k == 0 {
                        // The mean law moved into the linear part: − k̄ − c̄ f d/dθ.
                        for r in 0..len {
                            gs[(r, r)] -= mesh.k_mean;
                        }
                        for (q, &j) in self.orders.iter().enumerate().skip(1) {
                            let w = TAU * j as f64 * mesh.c_mean * f;
                            gs[(2 * q - 1, 2 * q)] -= w;
                            gs[(2 * q, 2 * q - 1)] += w;
                        }
                    }
                    // Boundary terms of the split points: coefficient · P φ(θ*) φ(θ*)ᵀ.
                    for (_, coefficient, phi) in acc.boundary.iter().filter(|b| b.0 == out) {
                        for r in 0..len {
                            let row = coefficient * factor(r) * phi[r];
                            for cl in 0..len {
                                gs[(r, cl)] += row * phi[cl];
                            }
                        }
                    }
                    // J[n', c] += R[n', out] ⊙ gs, c the output's own coordinate.
                    self.add_receptance_block(
                        &rec.r,
                        out,
                        self.output_coordinate(n, k),
                        &gs,
                        &mut jac,
                    );
                    // Split points on the mesh's other deflection (a mesh with a back row).
                    for (_, c, coefficient, phi) in acc.cross_boundary.iter().filter(|b| b.0 == out)
                    {
                        gs.fill(0.0);
                        for r in 0..len {
                            let row = coefficient * factor(r) * phi[r];
                            for cl in 0..len {
                                gs[(r, cl)] += row * phi[cl];
                            }
                        }
                        self.add_receptance_block(&rec.r, out, *c, &gs, &mut jac);
                    }
                }
            }
            jac
        });

        Evaluation {
            residual,
            jacobian,
            d_frequency,
            g,
            sample_w: acc.sample_w,
            sample_force: acc.sample_force,
            sample_lost: acc.sample_lost,
        }
    }

    /// `J[n', c] += R[n', out] ⊙ gs` for every coordinate `n'` (per order, on the rows): the
    /// receptance of output `out` times `gs = ∂g_out/∂s_c`.
    fn add_receptance_block(
        &self,
        r: &[DMatrix<Complex<f64>>],
        out: usize,
        c: usize,
        gs: &DMatrix<f64>,
        jac: &mut DMatrix<f64>,
    ) {
        let len = self.len;
        for n2 in 0..self.coordinates() {
            let mut block = jac.view_mut((n2 * len, c * len), (len, len));
            let r0 = r[0][(n2, out)].re;
            for cl in 0..len {
                block[(0, cl)] += r0 * gs[(0, cl)];
            }
            for q in 1..self.orders.len() {
                let rq = r[q][(n2, out)];
                for cl in 0..len {
                    let (a, b) = cmul(rq, gs[(2 * q - 1, cl)], gs[(2 * q, cl)]);
                    block[(2 * q - 1, cl)] += a;
                    block[(2 * q, cl)] += b;
                }
            }
        }
    }

    /// Adds `scale·T(κ)` to `gs`, or with `rate` `scale·T(κ)·D_θ` (`D_θ = d/dθ` on the
    /// coefficients): the Galerkin matrix `∂P[k(θ)·x(θ)]/∂x` of a signal `k` from its quadrature
    /// Fourier sums `κ_d = Σ w k (cos, sin)(2πdθ)` over [`Problem::sums`], by
    /// `cos_q cos_p = ½(cos_{q−p} + cos_{q+p})` and its siblings, which hold node by node: exact
    /// for the discrete residual (Toeplitz in the differences, Hankel in the sums).
    fn add_toeplitz(&self, kap: &[f64], scale: f64, rate: bool, gs: &mut DMatrix<f64>) {
        if kap.iter().all(|&x| x == 0.0) {
            return;
        }
        let no = self.orders.len();
        for q in 0..no {
            let fq = factor(q) * 0.5 * scale;
            let rows = if q == 0 { 1 } else { 2 };
            let row = |i: usize| if q == 0 { 0 } else { 2 * q - 1 + i };
            for p in 0..no {
                let (jq, jp) = (self.orders[q], self.orders[p]);
                let (ip, im) = (self.plus[q * no + p], self.minus[q * no + p]);
                let (c_plus, s_plus) = (kap[2 * ip], kap[2 * ip + 1]);
                let (c_minus, s_abs) = (kap[2 * im], kap[2 * im + 1]);
                // sin 2π(j_q − j_p)θ summed.
                let s_qp = if jq >= jp { s_abs } else { -s_abs };
                // 2 Σ w k [cos_q cos_p, cos_q sin_p; sin_q cos_p, sin_q sin_p].
                let block = [
                    [c_minus + c_plus, s_plus - s_qp],
                    [s_plus + s_qp, c_minus - c_plus],
                ];
                for (i, b) in block.iter().enumerate().take(rows) {
                    if !rate {
                        if p == 0 {
                            gs[(row(i), 0)] += fq * b[0];
                        } else {
                            gs[(row(i), 2 * p - 1)] += fq * b[0];
                            gs[(row(i), 2 * p)] += fq * b[1];
                        }
                    } else if p > 0 {
                        // (T D)[:, a_p] = −2πj_p T[:, b_p]; (T D)[:, b_p] = 2πj_p T[:, a_p].
                        let w = TAU * jp as f64;
                        gs[(row(i), 2 * p - 1)] -= fq * w * b[1];
                        gs[(row(i), 2 * p)] += fq * w * b[0];
                    }
                }
            }
        }
    }
}
