//! Byte layout of an element's part of an FMU state (FMI 2.0.x §2.1.8); the FMI layer wraps
//! it in its versioned, checksummed envelope ([`crate::fmi::blob`]).
//!
//! Layout, little-endian: `u32 n` then `n × (u32 vr, f64 value)` (parameters and start
//! inputs), `u8 flags` (bit 0 initialized, bits 1–3 the RK controller bits of
//! [`crate::fmu::payload::controller_bits`], bit 4 higher input derivatives follow),
//! `f64` start time, `f64` t, `u32 n_y` and the states, `u32 n_u`, the inputs, their rates
//! for the next step and their rates at `t` (for the output derivatives), with bit 4 their
//! second and third derivatives for the next step (`n_u` pairs; a state without them, as
//! written before they existed, has none), and the RK controller memory.

use crate::fmi::bytes::{put_f64s, Reader};
use crate::fmu::payload::{
    controller_bits, put_controller, put_params, read_controller, read_counted_params,
};
use crate::solve::rk::ControllerMemory;

/// Everything an element FMU needs to continue bit-identically.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementSnapshot {
    pub params: Vec<(u32, f64)>,
    pub start_time: f64,
    pub initialized: bool,
    pub t: f64,
    pub y: Vec<f64>,
    pub u: Vec<f64>,
    /// Input rates for the next step (first-order input interpolation).
    pub du: Vec<f64>,
    /// Second and third input derivatives for the next step.
    pub du_higher: Vec<[f64; 2]>,
    /// The inputs' rates at `t` (the output derivatives read them).
    pub du_now: Vec<f64>,
    pub controller: Option<ControllerMemory>,
}

/// An element's state as [`encode`] writes it, borrowed from the instance (a master saves a
/// state before every step: nothing is copied on the way to the bytes). The fields are those
/// of [`ElementSnapshot`].
pub struct ElementStateRef<'a> {
    pub params: &'a [(u32, f64)],
    pub start_time: f64,
    pub initialized: bool,
    pub t: f64,
    pub y: &'a [f64],
    pub u: &'a [f64],
    pub du: &'a [f64],
    pub du_higher: &'a [[f64; 2]],
    pub du_now: &'a [f64],
    pub controller: Option<ControllerMemory>,
}

impl ElementSnapshot {
    /// The snapshot as [`encode`] takes it.
    pub fn borrowed(&self) -> ElementStateRef<'_> {
        ElementStateRef {
            params: &self.params,
            start_time: self.start_time,
            initialized: self.initialized,
            t: self.t,
            y: &self.y,
            u: &self.u,
            du: &self.du,
            du_higher: &self.du_higher,
            du_now: &self.du_now,
            controller: self.controller,
        }
    }
}

/// At most this many states or inputs (an element has at most 3 and 4).
const MAX_LEN: usize = 16;

pub fn encode(s: &ElementStateRef) -> Vec<u8> {
    // Sized once (a master saves a state before every communication step): the layout above,
    // the controller memory at most 20 bytes.
    let higher = s.du_higher.iter().any(|d| *d != [0.0; 2]);
    let len = 4 + 12 * s.params.len() + 1 + 16 + 4 + 8 * s.y.len() + 4 + 40 * s.u.len() + 20;
    let mut out = Vec::with_capacity(len);
    put_params(&mut out, s.params);
    out.push(u8::from(s.initialized) | controller_bits(s.controller) << 1 | u8::from(higher) << 4);
    put_f64s(&mut out, &[s.start_time, s.t]);
    out.extend_from_slice(&(s.y.len() as u32).to_le_bytes());
    put_f64s(&mut out, s.y);
    out.extend_from_slice(&(s.u.len() as u32).to_le_bytes());
    put_f64s(&mut out, s.u);
    put_f64s(&mut out, s.du);
    put_f64s(&mut out, s.du_now);
    if higher {
        for d in s.du_higher {
            put_f64s(&mut out, d);
        }
    }
    put_controller(&mut out, s.controller);
    out
}

fn read_vec(r: &mut Reader, n: usize) -> Result<Vec<f64>, String> {
    (0..n).map(|_| r.f64()).collect()
}

fn read_len(r: &mut Reader, what: &str) -> Result<usize, String> {
    let n = r.u32()? as usize;
    if n > MAX_LEN {
        return Err(format!("model state lists {n} {what}"));
    }
    Ok(n)
}

pub fn decode(bytes: &[u8]) -> Result<ElementSnapshot, String> {
    let mut r = Reader::new(bytes);
    let params = read_counted_params(&mut r, bytes.len())?;
    let flags = r.u8()?;
    if flags >> 5 != 0 {
        return Err(format!("model state has unknown flags {flags:#04x}"));
    }
    let start_time = r.f64()?;
    let t = r.f64()?;
    let ny = read_len(&mut r, "states")?;
    let y = read_vec(&mut r, ny)?;
    let nu = read_len(&mut r, "inputs")?;
    let u = read_vec(&mut r, nu)?;
    let du = read_vec(&mut r, nu)?;
    let du_now = read_vec(&mut r, nu)?;
    let du_higher = if flags & 1 << 4 != 0 {
        (0..nu)
            .map(|_| Ok([r.f64()?, r.f64()?]))
            .collect::<Result<_, String>>()?
    } else {
        vec![[0.0; 2]; nu]
    };
    let controller = read_controller(&mut r, flags >> 1 & 7)?;
    r.finish("model state")?;
    Ok(ElementSnapshot {
        params,
        start_time,
        initialized: flags & 1 != 0,
        t,
        y,
        u,
        du,
        du_higher,
        du_now,
        controller,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_round_trips_and_rejects_truncation() {
        crate::fmu::payload::check_layout(
            |controller| ElementSnapshot {
                params: vec![(0, 0.01), (100, 0.5)],
                start_time: 0.25,
                initialized: true,
                t: 1.5,
                y: if controller.is_some() {
                    vec![1.0, 2.0, 3.0]
                } else {
                    vec![]
                },
                u: vec![-4.0, 0.5],
                du: vec![10.0, 0.0],
                du_higher: if controller.is_some() {
                    vec![[0.0; 2]; 2]
                } else {
                    vec![[1e3, 0.0], [0.0, -2e6]]
                },
                du_now: vec![0.0, -3.0],
                controller,
            },
            |s| encode(&s.borrowed()),
            decode,
        );
    }
}
