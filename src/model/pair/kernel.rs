//! Right-hand-side kernels of the single pair, specialised at assembly to the terms the scene
//! uses ("pay only for what you use").
//!
//! The mesh force of `docs/model.md` (Kahraman & Singh 1990 with the smooth terms of Bugaru
//! 2006 eq. 13) is
//! `F = k(p)(δ + b + δ̄ δ³) + γ δ³ + (c + c̃ cos 2πp) δ'` in contact, `δ = x − e(p)`, and the
//! external force `F_ext + F̃ cos 2πp` (torque ripple). A scene without STE, cubic springs,
//! damping variation or torque ripple need not evaluate their transcendental functions and
//! products at every stage: each combination of present terms is a monomorphised function
//! (const generics), picked once by [`Kernel::for_pair`]. [`Kernel::generic`] evaluates every
//! term with the scene's (possibly zero) coefficients; with zero coefficients every skipped
//! term is an exact `+ 0.0` or `· 1`, so both give bit-identical results (tested), and the
//! generic kernel serves as the oracle and the benchmark baseline.

use std::f64::consts::TAU;

use super::{ContactState, GearPair};

/// `F(t, y)`, the mesh force in the frozen contact state.
type ForceFn = fn(&GearPair, f64, &[f64]) -> f64;
/// `ÿ = (external − F) / m_e` as `dy`.
type RhsFn = fn(&GearPair, f64, &[f64], &mut [f64]);

/// The selected kernel: function pointers chosen at assembly.
#[derive(Clone, Copy)]
pub struct Kernel {
    pub force: ForceFn,
    pub rhs: RhsFn,
    /// Which terms the kernel evaluates (`generic`: all).
    pub name: &'static str,
}

impl std::fmt::Debug for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Kernel({})", self.name)
    }
}

macro_rules! kernel {
    ($ste:literal, $cubic:literal, $dvar:literal, $ripple:literal, $name:literal) => {
        Kernel {
            force: force::<$ste, $cubic, $dvar, false>,
            rhs: rhs::<$ste, $cubic, $dvar, $ripple, false>,
            name: $name,
        }
    };
}

impl Kernel {
    /// The kernel with only the terms `pair` uses; a run-up (a profile that varies) takes
    /// [`Kernel::runup`].
    pub fn for_pair(pair: &GearPair) -> Kernel {
        if pair
            .profiles()
            .is_some_and(|p| p.speed_varies() || p.torque_varies())
        {
            return Kernel::runup();
        }
        let s = &pair.smooth;
        let ste = !pair.ste.is_zero();
        let cubic = s.cubic_factor != 0.0 || s.cubic_spring != 0.0;
        let dvar = s.damping_variation != 0.0;
        let ripple = s.torque_ripple != 0.0;
        match (ste, cubic, dvar, ripple) {
            (false, false, false, false) => kernel!(false, false, false, false, "linear"),
            (false, false, false, true) => kernel!(false, false, false, true, "ripple"),
            (false, false, true, false) => kernel!(false, false, true, false, "dvar"),
            (false, false, true, true) => kernel!(false, false, true, true, "dvar+ripple"),
            (false, true, false, false) => kernel!(false, true, false, false, "cubic"),
            (false, true, false, true) => kernel!(false, true, false, true, "cubic+ripple"),
            (false, true, true, false) => kernel!(false, true, true, false, "cubic+dvar"),
            (false, true, true, true) => kernel!(false, true, true, true, "cubic+dvar+ripple"),
            (true, false, false, false) => kernel!(true, false, false, false, "ste"),
            (true, false, false, true) => kernel!(true, false, false, true, "ste+ripple"),
            (true, false, true, false) => kernel!(true, false, true, false, "ste+dvar"),
            (true, false, true, true) => kernel!(true, false, true, true, "ste+dvar+ripple"),
            (true, true, false, false) => kernel!(true, true, false, false, "ste+cubic"),
            (true, true, false, true) => kernel!(true, true, false, true, "ste+cubic+ripple"),
            (true, true, true, false) => kernel!(true, true, true, false, "ste+cubic+dvar"),
            (true, true, true, true) => Kernel::generic(),
        }
    }

    /// Every term, whatever the coefficients.
    pub fn generic() -> Kernel {
        kernel!(true, true, true, true, "generic")
    }

    /// Every term on a run-up (`docs/runup.md`): the phase quadratic in time, the STE rate at
    /// the instantaneous mesh frequency, the external force with the torque profile's ramp.
    /// Kept apart so that the constant-speed kernels keep their historical, shorter path.
    pub fn runup() -> Kernel {
        Kernel {
            force: force::<true, true, true, true>,
            rhs: rhs::<true, true, true, true, true>,
            name: "runup",
        }
    }
}

/// `(e, ė)` of the STE, `ė = f_m(t) de/dp` (the instantaneous mesh frequency: on a speed
/// ramp it varies); with `STE = false` the scene has none and nothing is evaluated.
#[inline(always)]
fn ste<const STE: bool, const RAMP: bool>(pair: &GearPair, t: f64, p: f64) -> (f64, f64) {
    if !STE {
        return (0.0, 0.0);
    }
    let (value, slope) = pair.ste.value_and_slope_unconditionally(p);
    let f = if RAMP {
        pair.clock.frequency_at(t)
    } else {
        pair.clock.mesh_frequency()
    };
    (value, slope * f)
}

/// Mesh phase at `t`: quadratic on a run-up, linear otherwise.
#[inline(always)]
fn phase<const RAMP: bool>(pair: &GearPair, t: f64) -> f64 {
    if RAMP {
        pair.clock.phase_at(t)
    } else {
        pair.clock.phase_at_constant_speed(t)
    }
}

#[inline(always)]
fn force<const STE: bool, const CUBIC: bool, const DVAR: bool, const RAMP: bool>(
    pair: &GearPair,
    t: f64,
    y: &[f64],
) -> f64 {
    let p = phase::<RAMP>(pair, t);
    let (e, e_rate) = ste::<STE, RAMP>(pair, t, p);
    let delta = y[0] - e;
    let delta_rate = y[1] - e_rate;
    let offset = match pair.contact {
        ContactState::Separated if pair.damping_always => return pair.damping * delta_rate,
        ContactState::Separated => return 0.0,
        ContactState::Drive => 0.0,
        ContactState::Back => pair.clearance(),
    };
    let k = pair.stiffness_at_phase(p);
    let damping = if DVAR {
        pair.damping + pair.smooth.damping_variation * (TAU * p).cos()
    } else {
        pair.damping
    };
    if CUBIC {
        // Bugaru 2006 eq. 13 (validation admits the cubic terms with the linear law only).
        let cubic = delta * delta * delta;
        k * ((delta + offset) + pair.smooth.cubic_factor * cubic)
            + pair.smooth.cubic_spring * cubic
            + damping * delta_rate
    } else {
        k * (delta + offset) + damping * delta_rate
    }
}

#[inline(always)]
fn rhs<
    const STE: bool,
    const CUBIC: bool,
    const DVAR: bool,
    const RIPPLE: bool,
    const RAMP: bool,
>(
    pair: &GearPair,
    t: f64,
    y: &[f64],
    dy: &mut [f64],
) {
    dy[0] = y[1];
    let mean = if RAMP {
        pair.external_force_at(t)
    } else {
        pair.f_ext
    };
    let external = if RIPPLE {
        mean + pair.ripple_force * (TAU * phase::<RAMP>(pair, t)).cos()
    } else {
        mean
    };
    dy[1] = (external - force::<STE, CUBIC, DVAR, RAMP>(pair, t, y)) / pair.m_e;
}
