//! The model part of an FMU state (FMI 2.0.x §2.1.8), [`Snapshot`], and the pieces the two
//! payload layouts (`state.rs` of [`crate::fmu::pair`] and of [`crate::fmu::drivetrain`])
//! write the same way: the parameter list and the RK controller memory of
//! [`crate::simulation::Driver`]. Each layout places them itself (its own flag byte, its own
//! order), so only the encoding is shared and both layouts stay byte-for-byte what they were.
//! The FMI layer wraps a payload in its versioned, checksummed envelope
//! ([`crate::fmi::blob`]).

use crate::fmi::bytes::{put_f64s, Reader};
use crate::solve::rk::ControllerMemory;

/// Everything a model needs to continue bit-identically, for either kernel: the values that
/// rebuild its equations and initial state, its life cycle and the run-time state `S` of its
/// simulation. `X` is what the kernel's settings hold besides the values of its Real
/// parameters (the pair's initial-DTE choice).
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot<S, X = ()> {
    /// Values of the parameters and start inputs, by value reference.
    pub params: Vec<(u32, f64)>,
    pub start_time: f64,
    pub initialized: bool,
    pub extra: X,
    pub sim: S,
}

/// `u32 n` then `n × (u32 vr, f64 value)`.
pub fn put_params(out: &mut Vec<u8>, params: &[(u32, f64)]) {
    out.extend_from_slice(&(params.len() as u32).to_le_bytes());
    for (vr, x) in params {
        out.extend_from_slice(&vr.to_le_bytes());
        out.extend_from_slice(&x.to_le_bytes());
    }
}

/// The `n` entries after a parameter count the caller has read and bounded.
pub fn read_params(r: &mut Reader, n: usize) -> Result<Vec<(u32, f64)>, String> {
    let mut params = Vec::with_capacity(n);
    for _ in 0..n {
        let vr = r.u32()?;
        params.push((vr, r.f64()?));
    }
    Ok(params)
}

/// A parameter count then its entries ([`put_params`]), the count bounded by the `payload_len`
/// bytes of the whole payload: each entry takes 12 bytes, so a count beyond that is corrupt,
/// not a huge allocation.
pub fn read_counted_params(r: &mut Reader, payload_len: usize) -> Result<Vec<(u32, f64)>, String> {
    let n = r.u32()? as usize;
    if n > payload_len / 12 {
        return Err(format!(
            "model state lists {n} parameters in {payload_len} bytes"
        ));
    }
    read_params(r, n)
}

/// Three flag bits, to be shifted into the layout's flag byte: bit 0 controller present,
/// bit 1 step proposal present, bit 2 last step rejected.
pub fn controller_bits(c: Option<ControllerMemory>) -> u8 {
    u8::from(c.is_some())
        | u8::from(c.is_some_and(|c| c.h.is_some())) << 1
        | u8::from(c.is_some_and(|c| c.last_rejected)) << 2
}

/// For RK: `f64` proposal (0 when absent), `f64` previous error, `u32` non-finite trials;
/// nothing for the exact propagator.
pub fn put_controller(out: &mut Vec<u8>, c: Option<ControllerMemory>) {
    if let Some(c) = c {
        put_f64s(out, &[c.h.unwrap_or(0.0), c.err_old]);
        out.extend_from_slice(&c.nonfinite_trials.to_le_bytes());
    }
}

/// Reads what [`put_controller`] wrote, given the [`controller_bits`] shifted back to bit 0.
pub fn read_controller(r: &mut Reader, bits: u8) -> Result<Option<ControllerMemory>, String> {
    if bits & 1 == 0 {
        return Ok(None);
    }
    let h = r.f64()?;
    let err_old = r.f64()?;
    let nonfinite_trials = r.u32()?;
    Ok(Some(ControllerMemory {
        h: (bits & 2 != 0).then_some(h),
        err_old,
        last_rejected: bits & 4 != 0,
        nonfinite_trials,
    }))
}

/// The checks every layout passes: `sample(c)` survives a round trip with each of the
/// [`sample_controllers`], and every truncation of its payload and one with a trailing byte
/// are rejected by `decode`. Returns the payload of `sample(None)` for the layout's own checks.
#[cfg(test)]
pub fn check_layout<S: PartialEq + std::fmt::Debug>(
    sample: impl Fn(Option<ControllerMemory>) -> S,
    encode: impl Fn(&S) -> Vec<u8>,
    decode: impl Fn(&[u8]) -> Result<S, String>,
) -> Vec<u8> {
    for c in sample_controllers() {
        let s = sample(c);
        assert_eq!(decode(&encode(&s)).unwrap(), s);
    }
    let bytes = encode(&sample(None));
    for n in 0..bytes.len() {
        assert!(decode(&bytes[..n]).is_err(), "truncation to {n} accepted");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    match decode(&longer) {
        Ok(_) => panic!("a trailing byte was accepted"),
        Err(e) => assert!(e.contains("trailing"), "{e}"),
    }
    bytes
}

/// The controller memories a payload round trip must preserve: none (exact propagator), one
/// with every flag set, one with none.
#[cfg(test)]
fn sample_controllers() -> [Option<ControllerMemory>; 3] {
    [
        None,
        Some(ControllerMemory {
            h: Some(1e-6),
            err_old: 0.3,
            last_rejected: true,
            nonfinite_trials: 2,
        }),
        Some(ControllerMemory {
            h: None,
            err_old: 1e-4,
            last_rejected: false,
            nonfinite_trials: 0,
        }),
    ]
}

/// The parameter and start-input values a saved state records, by value reference, kept once
/// the instance is initialized: from then on they no longer change (parameters are fixed and
/// the start inputs taken), and an error-controlled master saves a state at every step.
/// Dropped by a restore with other parameters and by a reset.
#[derive(Debug, Default)]
pub struct RecordedParams(std::cell::RefCell<Option<Vec<(u32, f64)>>>);

impl RecordedParams {
    /// The recorded values: `current()` before initialization, else the kept ones (computed by
    /// `current` the first time).
    pub fn get(
        &self,
        initialized: bool,
        current: impl FnOnce() -> Vec<(u32, f64)>,
    ) -> Vec<(u32, f64)> {
        self.with(initialized, current, <[(u32, f64)]>::to_vec)
    }

    /// `read` of the recorded values ([`RecordedParams::get`] without the copy: a state is
    /// saved before every step).
    pub fn with<R>(
        &self,
        initialized: bool,
        current: impl FnOnce() -> Vec<(u32, f64)>,
        read: impl FnOnce(&[(u32, f64)]) -> R,
    ) -> R {
        if !initialized {
            return read(&current());
        }
        read(self.0.borrow_mut().get_or_insert_with(current))
    }

    /// Forget the kept values (the parameters may change).
    pub fn clear(&mut self) {
        self.0.get_mut().take();
    }
}
