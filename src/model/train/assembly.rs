//! Assembly of a drivetrain into mass, base stiffness and damping matrices and one mesh vector
//! per mesh, in physical coordinates, and the reduction to elastic coordinates.
//!
//! # Coordinates and sign convention
//!
//! Gears joined by rigid shafts form one rotating *body* with one coordinate
//! `u_b = ρ_b θ_b` (m), `ρ_b` the base radius of the body's first gear and `θ_b` the vibratory
//! rotation **positive in the body's nominal rotation sense**. A gear with compliant bearings
//! adds translations `x, y` (m) in the scene frame. The deflection of mesh n (pinion a drives
//! gear b) along its line of action `ℓ_n` is
//!
//! `S_n = d_nᵀ q = r_a θ_a − r_b θ_b + (w_a − w_b)·ℓ_n`,  `ℓ_n = (cos β_n, sin β_n)`,
//! `β_n = centre_angle_n + σ_a·pressure_angle_n` (σ_a = +1 if the pinion turns ccw, −1 cw),
//!
//! positive when the drive flanks are compressed. This is Liu 2007 eq. (2.3) with the idler's
//! rotation counted in its own nominal sense (Liu's `u_2` is `−r_2θ_2` here) and
//! `β_2 = χ + π`; the mesh forces enter every equation through `d_n` (generalised force
//! `−F_n ∂S_n/∂q`), which is the energy-consistent form and carries the corrected `y_2` sign
//! (notes §1.2 [R], erratum §8 item 1). For one mesh, `S = r_b1θ1 + r_b2θ2` of
//! `docs/model.md` (θ2 there is counted against the gear's rotation).
//!
//! Equations (Liu 2007 eq. 2.6): `M q'' + C q' + K_b q + Σ_n d_n F_n = F_T`.
//!
//! # Rigid-body modes
//!
//! A train without ground coupling can turn freely: `R` spans the null space of
//! `K_b + Σ k̄_n d_n d_nᵀ` (it also lies in the null space of every `d_n`, whatever the contact
//! state). The motion is split as `q = Q ξ + R η` with `D Q = I` and `Rᵀ M Q = 0`, where the rows
//! of `D` are the mesh vectors first (then shaft twists, then unit vectors), chosen greedily
//! (Liu 2007 eq. 3.2: `u = Qx + rigid body`, `Q` mass-orthogonal to the rigid mode; notes §2.1
//! and §3.1). The elastic coordinates `ξ` are then the mesh deflections themselves where
//! possible, and `M̂ = QᵀMQ` reproduces eq. (3.2) and the missing `M̂` of Ch. 4 (notes §3.1).
//! The rigid motion decouples exactly (ground dampers on a freely turning train, which would
//! couple it, are rejected by the scene validation): `η'' = (RᵀMR)⁻¹ Rᵀ F_T`, zero for
//! balanced torques.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use crate::scene::train::ShaftCoupling;
use crate::scene::Scene;

/// What a physical coordinate is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DofKind {
    /// Rotation of a body, `u_b = ρ_b θ_b` (m); `gear` is the body's first gear.
    Rotation { gear: usize },
    /// Bearing translation of a gear along the scene's x axis (m).
    X { gear: usize },
    /// Bearing translation along y (m).
    Y { gear: usize },
    /// A planet's radial translation ζ in its carrier's frame (m; `docs/planetary.md`).
    Radial { gear: usize },
    /// A planet's tangential translation η in its carrier's frame, in the stage's sense (m).
    Tangential { gear: usize },
}

/// The assembled drivetrain in physical coordinates.
#[derive(Debug, Clone)]
pub struct Assembly {
    pub dofs: Vec<DofKind>,
    pub labels: Vec<String>,
    /// Body index of every gear.
    pub body_of: Vec<usize>,
    /// Rotation DOF of every body.
    pub body_dof: Vec<usize>,
    /// Reference radius `ρ_b` of every body.
    pub body_radius: Vec<f64>,
    pub mass: DMatrix<f64>,
    /// Bearings, shafts and ground couplings.
    pub k_base: DMatrix<f64>,
    pub c_base: DMatrix<f64>,
    /// The ground couplings alone (part of `k_base`).
    pub k_ground: DMatrix<f64>,
    /// Mesh deflection vectors `d_n`.
    pub mesh: Vec<DVector<f64>>,
    /// Back-flank deflection vectors `d̃_n` (`flanks::back_line_of_action`): equal to `d_n` but for the
    /// translations, which act along the back flanks' own line of action; `d_n` itself for a
    /// mesh whose back side cannot touch (no backlash).
    pub mesh_back: Vec<DVector<f64>>,
    /// Rotational part of `d_n`: the DTE `r_a θ_a − r_b θ_b`.
    pub dte: Vec<DVector<f64>>,
    /// Mean mesh stiffness `k̄_n`.
    pub mean_stiffness: Vec<f64>,
    /// Generalised force per N·m of input torque.
    pub input_load: DVector<f64>,
    /// Generalised force per N·m of load torque (magnitude, resisting).
    pub output_load: DVector<f64>,
    /// Twist vectors of the elastic shafts (candidates for elastic coordinates).
    pub shaft_twist: Vec<DVector<f64>>,
    /// Per mesh with tooth friction: the sliding-direction vectors of [`FrictionVectors`].
    pub friction: Vec<Option<FrictionVectors>>,
    /// Generalised force of the planets' pin position errors, `−Σ k b e` (a static preload of
    /// the planet bearings, `docs/planetary.md` eq. P8); zero without planets.
    pub pin_load: DVector<f64>,
    /// The rotating carrier frames' gyroscopic terms, with `gyroscopic = true` on a stage
    /// (`docs/planetary.md`, "Gyroscopic terms"); their centripetal softening is in `k_base`.
    pub frame: Option<FrameTerms>,
}

/// The gyroscopic matrix `Ω_c G` of the stages with `gyroscopic = true` (Lin & Parker 1999
/// eq. 1; [`super::planetary::frame_terms`]), a skew velocity term: the time-domain model
/// adds it to the damping, `modes` solves the gyroscopic eigenproblem with it.
#[derive(Debug, Clone)]
pub struct FrameTerms {
    pub gyroscopic: DMatrix<f64>,
    /// The input speed the terms were assembled at, rad/s: a change of speed needs them
    /// assembled anew.
    pub input_speed: f64,
}

/// Generalised direction of the friction force of a tooth pair of a mesh with friction:
/// `t(l) = base + l·per_arm`, `l` the pair's contact distance from the pinion's base tangent
/// point. A friction force `f` (N, on the pinion along the flanks' common off-line-of-action
/// velocity `ê_s = σ_a ẑ × ℓ`, equal and opposite on the gear) does the virtual work
/// `f tᵀδq`: it turns the pinion with arm `l`, the gear with arm `D − l` (against its
/// rotation) and pushes the bearings along `±ê_s` (Liu 2007 eq. 4.44's `L` matrix, formed by
/// virtual work instead of transcribed: notes §4.3).
#[derive(Debug, Clone)]
pub struct FrictionVectors {
    /// `−(D/ρ_b) e_{u_b} + ê_s·(e_{w_a} − e_{w_b})`.
    pub base: DVector<f64>,
    /// `e_{u_a}/ρ_a + e_{u_b}/ρ_b` (per metre of arm).
    pub per_arm: DVector<f64>,
}

impl Assembly {
    pub fn new(scene: &Scene) -> Assembly {
        let ng = scene.gears.len();
        // Bodies: gears joined by rigid shafts (union-find).
        let mut parent: Vec<usize> = (0..ng).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for s in &scene.shafts {
            if s.coupling == ShaftCoupling::Rigid {
                let (a, b) = (root(&mut parent, s.gears[0]), root(&mut parent, s.gears[1]));
                if a != b {
                    parent[a.max(b)] = a.min(b);
                }
            }
        }
        let mut body_of = vec![usize::MAX; ng];
        let mut body_first = Vec::new();
        for g in 0..ng {
            let r = root(&mut parent, g);
            if body_of[r] == usize::MAX {
                body_of[r] = body_first.len();
                body_first.push(r);
            }
            body_of[g] = body_of[r];
        }
        let body_radius: Vec<f64> = body_first
            .iter()
            .map(|&g| scene.gears[g].base_radius)
            .collect();

        // Lines of action.
        let loa: Vec<(f64, f64)> = scene
            .meshes
            .iter()
            .map(|m| {
                let beta = m.centre_angle + scene.rotation[m.pinion] * m.pressure_angle;
                let (s, c) = beta.sin_cos();
                (c, s)
            })
            .collect();
        // The back flanks' line of action (`flanks::back_line_of_action`), for meshes whose back side
        // can touch.
        let back_loa: Vec<Option<(f64, f64)>> = scene
            .meshes
            .iter()
            .zip(&loa)
            .map(|(m, &l)| {
                let backlash = matches!(m.contact, crate::scene::ContactLaw::Backlash { .. });
                (backlash && m.pressure_angle != 0.0).then(|| {
                    super::flanks::back_line_of_action(
                        l,
                        super::flanks::centre_line(l, scene.rotation[m.pinion], m.pressure_angle),
                    )
                })
            })
            .collect();
        // Direction of the tooth flanks' off-line-of-action velocity, `ê_s = σ_a ẑ × ℓ`, along
        // which friction acts (Liu 2007 Ch. 5: the friction force is perpendicular to the
        // line of action).
        let sliding: Vec<(f64, f64)> = scene
            .meshes
            .iter()
            .zip(&loa)
            .map(|(m, l)| {
                let s = scene.rotation[m.pinion];
                (-s * l.1, s * l.0)
            })
            .collect();
        // A bearing direction no line of action has a component along carries no force and
        // is never excited: its DOF is omitted (Liu 2007 §2.2 drops y_1 for this reason).
        // With tooth friction the off-line-of-action direction carries the friction force.
        let coupled = |g: usize, axis: usize| {
            let along = |v: &(f64, f64)| if axis == 0 { v.0 } else { v.1 };
            scene
                .meshes
                .iter()
                .zip(loa.iter().zip(&sliding).zip(&back_loa))
                .any(|(m, ((l, e), back))| {
                    (m.pinion == g || m.gear == g)
                        && (along(l) != 0.0
                            || (m.friction.is_some() && along(e) != 0.0)
                            || back.is_some_and(|b| along(&b) != 0.0))
                })
                || super::planetary::in_carrier_frame(scene, g)
        };

        let mut dofs = Vec::new();
        let mut body_dof = vec![usize::MAX; body_first.len()];
        let mut trans = vec![[usize::MAX; 2]; ng];
        for g in 0..ng {
            if scene.gears[g].bearing.is_some() {
                for (axis, slot) in trans[g].iter_mut().enumerate() {
                    if coupled(g, axis) {
                        *slot = dofs.len();
                        let planet = super::planetary::is_planet(scene, g);
                        dofs.push(match (axis, planet) {
                            (0, false) => DofKind::X { gear: g },
                            (_, false) => DofKind::Y { gear: g },
                            (0, true) => DofKind::Radial { gear: g },
                            (_, true) => DofKind::Tangential { gear: g },
                        });
                    }
                }
            }
            let b = body_of[g];
            if body_dof[b] == usize::MAX {
                body_dof[b] = dofs.len();
                dofs.push(DofKind::Rotation { gear: g });
            }
        }
        let n = dofs.len();
        let labels = dofs
            .iter()
            .map(|d| match *d {
                DofKind::Rotation { gear } => format!("{}.u", scene.gears[gear].name),
                DofKind::X { gear } => format!("{}.x", scene.gears[gear].name),
                DofKind::Y { gear } => format!("{}.y", scene.gears[gear].name),
                DofKind::Radial { gear } => format!("{}.radial", scene.gears[gear].name),
                DofKind::Tangential { gear } => format!("{}.tangential", scene.gears[gear].name),
            })
            .collect();

        let mut mass = DMatrix::zeros(n, n);
        let mut k_base = DMatrix::zeros(n, n);
        let mut c_base = DMatrix::zeros(n, n);
        let mut k_ground = DMatrix::zeros(n, n);
        for (g, gear) in scene.gears.iter().enumerate() {
            let b = body_of[g];
            let (u, rho) = (body_dof[b], body_radius[b]);
            mass[(u, u)] += gear.inertia / (rho * rho);
            k_base[(u, u)] += gear.ground_stiffness / (rho * rho);
            // A planetary stage's ground coupling is the support that reacts its torque (the
            // held ring, docs/planetary.md): it carries mean torque, unlike the vibratory
            // couplings of Liu 2007 eq. (2.8).
            if !super::planetary::in_carrier_frame(scene, g) {
                k_ground[(u, u)] += gear.ground_stiffness / (rho * rho);
            }
            c_base[(u, u)] += gear.ground_damping / (rho * rho);
            if let Some(bearing) = gear.bearing {
                // A planet's bearing is on its carrier's pin (below), not to ground.
                let grounded = !super::planetary::is_planet(scene, g);
                for (axis, &i) in trans[g].iter().enumerate() {
                    if i != usize::MAX {
                        mass[(i, i)] += gear.mass.expect("validated: bearing has mass");
                        if grounded {
                            k_base[(i, i)] += bearing.stiffness[axis];
                            c_base[(i, i)] += bearing.damping[axis];
                        }
                    }
                }
            }
        }
        let rot = |g: usize| -> DVector<f64> {
            let b = body_of[g];
            let mut v = DVector::zeros(n);
            v[body_dof[b]] = 1.0 / body_radius[b];
            v
        };
        let mut shaft_twist = Vec::new();
        for s in &scene.shafts {
            if let ShaftCoupling::Elastic { stiffness, damping } = s.coupling {
                let v = rot(s.gears[0]) - rot(s.gears[1]);
                k_base += stiffness * &v * v.transpose();
                c_base += damping * &v * v.transpose();
                shaft_twist.push(v);
            }
        }

        let at = super::planetary::Coordinates {
            n,
            theta: &rot,
            trans: &trans,
        };
        let mut pin_load = DVector::zeros(n);
        for spring in super::planetary::pin_springs(scene, &at) {
            let bb = &spring.b * spring.b.transpose();
            k_base += spring.stiffness * &bb;
            c_base += spring.damping * &bb;
            pin_load -= &spring.b * (spring.stiffness * spring.error);
        }
        let frame = super::planetary::frame_terms(scene, &trans, n).map(|(g, k_omega)| {
            k_base -= k_omega;
            FrameTerms {
                gyroscopic: g,
                input_speed: scene.operating.input_speed,
            }
        });
        let mut mesh = Vec::new();
        let mut mesh_back = Vec::new();
        let mut dte = Vec::new();
        for (i, (m, l)) in scene.meshes.iter().zip(&loa).enumerate() {
            let backlash = matches!(m.contact, crate::scene::ContactLaw::Backlash { .. });
            if let Some((d, back, rotational)) = super::planetary::mesh_vector(scene, &at, i) {
                mesh_back.push(if backlash { back } else { d.clone() });
                mesh.push(d);
                dte.push(rotational);
                continue;
            }
            let (a, b) = (m.pinion, m.gear);
            let r_a = scene.gears[a].base_radius;
            let r_b = scene.gears[b].base_radius;
            let mut d = DVector::zeros(n);
            d[body_dof[body_of[a]]] += r_a / body_radius[body_of[a]];
            d[body_dof[body_of[b]]] -= r_b / body_radius[body_of[b]];
            dte.push(d.clone());
            let along = |l: (f64, f64)| {
                let mut d = d.clone();
                for (g, sign) in [(a, 1.0), (b, -1.0)] {
                    if trans[g][0] != usize::MAX {
                        d[trans[g][0]] += sign * l.0;
                    }
                    if trans[g][1] != usize::MAX {
                        d[trans[g][1]] += sign * l.1;
                    }
                }
                d
            };
            let drive = along(*l);
            mesh_back.push(back_loa[i].map_or_else(|| drive.clone(), along));
            mesh.push(drive);
        }
        let friction = scene
            .meshes
            .iter()
            .zip(&sliding)
            .map(|(m, e)| {
                let fr = m.friction.as_ref()?;
                let (ba, bb) = (body_of[m.pinion], body_of[m.gear]);
                let mut base = DVector::zeros(n);
                let mut per_arm = DVector::zeros(n);
                base[body_dof[bb]] -= fr.loa_length / body_radius[bb];
                per_arm[body_dof[ba]] += 1.0 / body_radius[ba];
                per_arm[body_dof[bb]] += 1.0 / body_radius[bb];
                for (g, sign) in [(m.pinion, 1.0), (m.gear, -1.0)] {
                    if trans[g][0] != usize::MAX {
                        base[trans[g][0]] += sign * e.0;
                    }
                    if trans[g][1] != usize::MAX {
                        base[trans[g][1]] += sign * e.1;
                    }
                }
                Some(FrictionVectors { base, per_arm })
            })
            .collect();
        let mean_stiffness = scene.meshes.iter().map(|m| m.mean_stiffness()).collect();
        // A torque T on a gear of body b does work T δθ = (T/ρ_b) δu_b.
        let input_load = rot(scene.input_gear);
        let output_load = -rot(scene.output_gear);
        Assembly {
            dofs,
            labels,
            body_of,
            body_dof,
            body_radius,
            mass,
            k_base,
            c_base,
            k_ground,
            mesh,
            mesh_back,
            dte,
            mean_stiffness,
            input_load,
            output_load,
            shaft_twist,
            friction,
            pin_load,
            frame,
        }
    }

    pub fn dim(&self) -> usize {
        self.dofs.len()
    }

    /// Mean stiffness matrix `K_b + Σ k̄_n d_n d_nᵀ` (all pairs in contact; with the rotating
    /// frames' terms, `K_b` includes their centripetal softening `−Ω_c² K_Ω`).
    pub fn mean_stiffness_matrix(&self) -> DMatrix<f64> {
        let mut k = self.k_base.clone();
        for (d, &kn) in self.mesh.iter().zip(&self.mean_stiffness) {
            k += kn * d * d.transpose();
        }
        k
    }

    /// Generalised external force for input torque `t_in` and load torque `t_load`.
    pub fn load(&self, t_in: f64, t_load: f64) -> DVector<f64> {
        &self.input_load * t_in + &self.output_load * t_load
    }
}

/// Iterations per matrix dimension allowed to nalgebra's symmetric-eigen and SVD sweeps (they
/// converge in a few per dimension for finite, representable matrices; entries near the
/// bottom of the double range made the SVD loop without end, issue 34). A decomposition that
/// needs more is refused rather than left spinning.
const ITERATIONS_PER_DIM: usize = 200;

/// Eigen-decomposition of `(K, M)` for symmetric `K` and symmetric positive definite `M`:
/// eigenvalues `ω²` ascending and `M`-orthonormal vectors (columns).
pub fn generalized_eigen(k: &DMatrix<f64>, m: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    try_generalized_eigen(k, m).expect("mass matrix is positive definite")
}

/// [`generalized_eigen`] with its failures as errors: a mass matrix that is not positive
/// definite, matrices that are not finite, or an eigen-iteration beyond its cap.
pub fn try_generalized_eigen(
    k: &DMatrix<f64>,
    m: &DMatrix<f64>,
) -> Result<(Vec<f64>, DMatrix<f64>), String> {
    let n = k.nrows();
    if !(k.iter().chain(m.iter()).all(|x| x.is_finite())) {
        return Err("the mass or stiffness matrix is not finite".into());
    }
    let chol = m
        .clone()
        .cholesky()
        .ok_or("the mass matrix is not positive definite")?;
    let l = chol.l();
    let l_inv = l
        .clone()
        .try_inverse()
        .ok_or("the mass matrix's Cholesky factor is singular")?;
    let a = &l_inv * k * l_inv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    if !a.iter().all(|x| x.is_finite()) {
        return Err("the mass-normalised stiffness matrix is not finite".into());
    }
    let eig =
        SymmetricEigen::try_new(a, f64::EPSILON, ITERATIONS_PER_DIM * n.max(1)).ok_or(format!(
            "the eigenvalues of the {n}×{n} mean system did not converge within {} iterations",
            ITERATIONS_PER_DIM * n.max(1)
        ))?;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let values = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    let mut vectors = DMatrix::zeros(n, n);
    for (c, &i) in order.iter().enumerate() {
        let v = l_inv.transpose() * eig.eigenvectors.column(i);
        vectors.set_column(c, &v);
    }
    Ok((values, vectors))
}

/// Relative size below which an eigenvalue of the mean system counts as a rigid-body mode.
const RIGID_TOL: f64 = 1e-10;

/// The split `q = Q ξ + R η` into elastic and rigid-body coordinates.
#[derive(Debug, Clone)]
pub struct Reduction {
    /// `n × m`, `m = n − r`.
    pub q: DMatrix<f64>,
    /// `n × r`, `M`-orthonormal rigid-body modes.
    pub r: DMatrix<f64>,
    /// `m × n`: the rows of `D` (`ξ = D q` on the elastic motion, `DQ = I`).
    pub d: DMatrix<f64>,
}

impl Reduction {
    /// The split of an assembly. Refuses, with the spread of its masses, an assembly whose
    /// matrices are not finite or whose rigid-body modes cannot be told from its elastic ones
    /// (issue 17: a gear inertia of 1e20 kg.m2 next to 1e-2 made the split panic): the
    /// smallest elastic eigenvalue `~k/m_max` must stay above [`RIGID_TOL`] times the largest
    /// `~k/m_min`, which fails once the masses span more than ~1/RIGID_TOL = 1e10.
    pub fn new(asm: &Assembly) -> Result<Reduction, String> {
        let n = asm.dim();
        let k_mean = asm.mean_stiffness_matrix();
        let diagonal = asm.mass.diagonal();
        let (m_min, m_max) = diagonal
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &m| (a.min(m), b.max(m)));
        let spread = || {
            format!(
                "the drivetrain's masses (inertias over base radius squared, and bearing \
                 masses) span {m_min:e} to {m_max:e} kg"
            )
        };
        let finite = |m: &DMatrix<f64>| m.iter().all(|x| x.is_finite());
        if !(finite(&asm.mass) && finite(&k_mean) && m_min > 0.0) {
            return Err(format!(
                "{}: its mass or mean stiffness matrix is not finite and positive",
                spread()
            ));
        }
        let unseparable = || {
            format!(
                "{}: beyond a ratio of ~1e10 the rigid-body modes cannot be told from the \
                 elastic ones (eigenvalues resolved to a relative {RIGID_TOL:e})",
                spread()
            )
        };
        let (values, vectors) =
            try_generalized_eigen(&k_mean, &asm.mass).map_err(|e| format!("{}: {e}", spread()))?;
        let top = values.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
        let rigid: Vec<usize> = (0..n)
            .filter(|&i| values[i].abs() <= RIGID_TOL * top)
            .collect();
        let mut r = DMatrix::zeros(n, rigid.len());
        for (c, &i) in rigid.iter().enumerate() {
            r.set_column(c, &vectors.column(i));
        }
        if rigid.is_empty() {
            return Ok(Reduction {
                q: DMatrix::identity(n, n),
                r,
                d: DMatrix::identity(n, n),
            });
        }
        let rm = r.transpose() * &asm.mass; // r × n
        let mut rows: Vec<DVector<f64>> = Vec::new();
        let candidates = asm
            .mesh
            .iter()
            .cloned()
            .chain(asm.shaft_twist.iter().cloned())
            .chain((0..n).map(|i| {
                let mut e = DVector::zeros(n);
                e[i] = 1.0;
                e
            }));
        let m_el = n - rigid.len();
        for c in candidates {
            if rows.len() == m_el {
                break;
            }
            let mut trial = rows.clone();
            trial.push(c.clone());
            let stacked = stack(&trial, &rm);
            if full_row_rank(&stacked).ok_or_else(unseparable)? {
                rows = trial;
            }
        }
        if rows.len() != m_el {
            return Err(unseparable());
        }
        // Square and of full rank by construction, up to rounding.
        let t_inv = stack(&rows, &rm).try_inverse().ok_or_else(unseparable)?;
        let q = t_inv.columns(0, m_el).clone_owned();
        // The reduced mass matrix must stay positive definite in floating point: every
        // decomposition downstream (modal damping, modes, statics) factorises it.
        if (q.transpose() * &asm.mass * &q).cholesky().is_none() {
            return Err(unseparable());
        }
        let d = stack(&rows, &DMatrix::zeros(0, n));
        Ok(Reduction { q, r, d })
    }

    /// `M̂⁻¹Qᵀ` (`m × n`) without `M̂⁻¹`: the elastic acceleration of a physical force `f` is
    /// `ξ'' = M̂⁻¹Qᵀf`. With `D_el = D(I − R RᵀM)` (still `D_el Q = I`, and `D_el R = 0`),
    /// `[D_el; RᵀM]` is the inverse of `[Q R]`, so `Q D_el + R RᵀM = I` and
    /// `M̂ D_el M⁻¹ = QᵀM(I − R RᵀM)M⁻¹ = Qᵀ`: `M̂⁻¹Qᵀ = D_el M⁻¹ = D M⁻¹ − (DR)Rᵀ`.
    ///
    /// Issue 37: on a free train `ξ` are mesh deflections, `Q` sums them along the train
    /// and `M̂` grows ill-conditioned with its length (cond 3e3, 2e5, 1e7 for chains of 4, 16
    /// and 64 compliant meshes). The products `M̂⁻¹K̂` and `M̂⁻¹F̂` formed through the computed
    /// `M̂⁻¹` then carry errors of `cond(M̂)·ε` that do not cancel the way they do in the
    /// right-hand side `M̂⁻¹(F̂ − K̂ξ)`: the exact propagator's segment matrices moved every
    /// segment's equilibrium, by 1.7e-9 of the static deflection on 16 meshes and 1.5e-6 on 64.
    /// Here the inverse is that of the physical mass matrix (diagonal up to the carrier
    /// frames, condition ~1), and `Q` enters only as a right factor.
    pub fn inverse_mass_rows(&self, asm: &Assembly) -> Result<DMatrix<f64>, String> {
        let minv = asm
            .mass
            .clone()
            .try_inverse()
            .ok_or("the mass matrix is singular")?;
        Ok(&self.d * minv - (&self.d * &self.r) * self.r.transpose())
    }

    pub fn elastic_dim(&self) -> usize {
        self.q.ncols()
    }

    pub fn rigid_dim(&self) -> usize {
        self.r.ncols()
    }
}

/// The elastic static solution of a free train, `QᵀK̄Q ξ = Qᵀf`, solved in the physical
/// coordinates (issue 37): `K̄ q + MR λ = f`, `(MR)ᵀq = 0` (the bordered system, `MR` scaled
/// to `K̄`'s size), then `ξ = D_el q`. The reduced `QᵀK̄Q` has the condition of `K̄` on the
/// elastic motion times about `cond(Q)²` (7e7 on a free 64-mesh compliant chain, where its
/// solution was 1.1e-9 of the static deflection off); the bordered physical matrix only
/// its own.
#[derive(Debug, Clone)]
pub struct FreeStatics {
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    /// `n + r`.
    size: usize,
    d_el: DMatrix<f64>,
}

impl FreeStatics {
    /// For the mean stiffness of `asm` (`None` for a grounded train).
    pub fn new(asm: &Assembly, red: &Reduction) -> Option<FreeStatics> {
        let (n, r) = (asm.dim(), red.rigid_dim());
        if r == 0 {
            return None;
        }
        let k = asm.mean_stiffness_matrix();
        let mr = &asm.mass * &red.r;
        let scale = k.amax() / mr.amax();
        let mut bordered = DMatrix::zeros(n + r, n + r);
        bordered.view_mut((0, 0), (n, n)).copy_from(&k);
        bordered.view_mut((0, n), (n, r)).copy_from(&(&mr * scale));
        bordered
            .view_mut((n, 0), (r, n))
            .copy_from(&(mr.transpose() * scale));
        let d_el = &red.d - (&red.d * &red.r) * mr.transpose();
        Some(FreeStatics {
            lu: bordered.lu(),
            size: n + r,
            d_el,
        })
    }

    /// `ξ` of the physical static force `f`, or `None` if the matrix is singular.
    pub fn solve(&self, f: &DVector<f64>) -> Option<DVector<f64>> {
        let n = f.len();
        let mut rhs = DVector::zeros(self.size);
        rhs.rows_mut(0, n).copy_from(f);
        let x = self.lu.solve(&rhs)?;
        Some(&self.d_el * x.rows(0, n))
    }
}

fn stack(rows: &[DVector<f64>], rm: &DMatrix<f64>) -> DMatrix<f64> {
    let n = rm.ncols();
    let mut t = DMatrix::zeros(rows.len() + rm.nrows(), n);
    for (i, row) in rows.iter().enumerate() {
        t.set_row(i, &row.transpose());
    }
    for i in 0..rm.nrows() {
        t.set_row(rows.len() + i, &rm.row(i));
    }
    t
}

/// Whether the rows of `a` are independent by a margin: its rows scaled to unit length
/// (masses and radii then do not count as dependence) have a smallest singular value above
/// [`INDEPENDENT_ROWS`] of the largest. A row that adds a direction only through the rounding
/// of the rigid-body modes must not pass: issue 34 found a bearing stiffness of 8 N/m next
/// to 1.5e8 N/m mixing a 1e-7 part of the soft translation into the rigid rotation, a
/// 1e-8-independent row accepted, and the reduced mass matrix lost to cancellation (a panic
/// in its Cholesky factorisation). `None` when the SVD does not converge within its cap.
fn full_row_rank(a: &DMatrix<f64>) -> Option<bool> {
    let mut a = a.clone();
    for mut row in a.row_iter_mut() {
        let norm = row.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            return Some(false);
        }
        row /= norm;
    }
    let cap = ITERATIONS_PER_DIM * a.nrows().max(a.ncols()).max(1);
    let (rows, cols) = a.shape();
    let svd = a.try_svd(false, false, f64::EPSILON, cap)?;
    let s = &svd.singular_values;
    let max = s.iter().fold(0.0f64, |a, &b| a.max(b));
    let min = s.iter().fold(f64::INFINITY, |a, &b| a.min(b));
    Some(s.len() == rows.min(cols) && min > INDEPENDENT_ROWS * max)
}

/// Relative smallest singular value of unit rows counted as independent (see
/// [`full_row_rank`]): well above the ~1e-7 that rounding mixes into nearly rigid modes,
/// far below the spread of any real layout.
const INDEPENDENT_ROWS: f64 = 1e-5;
