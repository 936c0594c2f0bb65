//! Byte layout of the gear pair's part of an FMU state (FMI 2.0.x §2.1.8). The FMI layer
//! wraps it in its versioned, checksummed envelope ([`crate::fmi::blob`]); this module only
//! turns a [`PairSnapshot`] into bytes and back, rejecting anything malformed with a reason.
//!
//! Layout, little-endian: `u32 n` then `n × (u32 vr, f64 value)` (parameters and start
//! inputs), `u8 flags` (bit 0 static initial DTE, bit 1 initialized, bit 2 RK controller
//! present, bit 3 controller step proposal present, bit 4 last step rejected), `f64`
//! initial DTE, start time, t, x, x', the three inputs, the clock (t0, p0, f_m), segment
//! cycle, `u64` segment piece, `i8` contact state, and for RK `f64` proposal, `f64`
//! previous error, `u32` non-finite trials.

use super::InitialDteChoice;
use crate::fmi::bytes::Reader;
use crate::fmu::payload::{
    controller_bits, put_controller, put_params, read_controller, read_counted_params, Snapshot,
};
use crate::model::{ContactState, Inputs, PairState, PhaseClock};
use crate::simulation::SimState;

/// Everything the gear pair needs to continue bit-identically.
pub type PairSnapshot = Snapshot<SimState, InitialDteChoice>;

pub fn encode(s: &PairSnapshot) -> Vec<u8> {
    let mut out = Vec::with_capacity(256);
    put_params(&mut out, &s.params);
    let c = s.sim.controller;
    let flags =
        u8::from(s.extra.static_dte) | u8::from(s.initialized) << 1 | controller_bits(c) << 2;
    out.push(flags);
    let p = &s.sim.pair;
    let (t0, p0) = p.clock.anchor();
    for x in [
        s.extra.initial_dte,
        s.start_time,
        s.sim.t,
        s.sim.y[0],
        s.sim.y[1],
        p.inputs.pinion_speed,
        p.inputs.input_torque,
        p.inputs.load_torque,
        t0,
        p0,
        p.clock.mesh_frequency(),
        p.segment_cycle,
    ] {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out.extend_from_slice(&(p.segment_piece as u64).to_le_bytes());
    out.push(p.contact as i8 as u8);
    put_controller(&mut out, c);
    out
}

pub fn decode(bytes: &[u8]) -> Result<PairSnapshot, String> {
    let mut r = Reader::new(bytes);
    let params = read_counted_params(&mut r, bytes.len())?;
    let flags = r.u8()?;
    let mut f = [0.0; 12];
    for x in &mut f {
        *x = r.f64()?;
    }
    let piece = r.u64()?;
    let contact = r.u8()?;
    let contact = match contact as i8 {
        1 => ContactState::Drive,
        0 => ContactState::Separated,
        -1 => ContactState::Back,
        other => return Err(format!("model state has contact state {other}")),
    };
    let controller = read_controller(&mut r, flags >> 2)?;
    r.finish("model state")?;
    Ok(PairSnapshot {
        params,
        extra: InitialDteChoice {
            static_dte: flags & 1 != 0,
            initial_dte: f[0],
        },
        start_time: f[1],
        initialized: flags & 2 != 0,
        sim: SimState {
            t: f[2],
            y: [f[3], f[4]],
            pair: PairState {
                inputs: Inputs {
                    pinion_speed: f[5],
                    input_torque: f[6],
                    load_torque: f[7],
                },
                clock: PhaseClock::new(f[8], f[9], f[10]),
                segment_cycle: f[11],
                segment_piece: usize::try_from(piece)
                    .map_err(|_| format!("model state has segment piece {piece}"))?,
                contact,
            },
            controller,
        },
    })
}

/// A snapshot with every field set, for the payload tests of both layouts.
#[cfg(test)]
pub(crate) fn sample(controller: Option<crate::solve::rk::ControllerMemory>) -> PairSnapshot {
    PairSnapshot {
        params: vec![(0, 0.5), (7, -1.25)],
        extra: InitialDteChoice {
            static_dte: true,
            initial_dte: 7e-6,
        },
        start_time: 0.5,
        initialized: true,
        sim: SimState {
            t: 0.125,
            y: [1e-6, -2e-3],
            pair: PairState {
                inputs: Inputs {
                    pinion_speed: 400.0,
                    input_torque: 100.0,
                    load_torque: 140.0,
                },
                clock: PhaseClock::new(0.1, 3.25, 2500.0),
                segment_cycle: 3.0,
                segment_piece: 1,
                contact: ContactState::Back,
            },
            controller,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_malformed_payloads() {
        let mut huge = crate::fmu::payload::check_layout(sample, encode, decode);
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge).unwrap_err().contains("parameters"));
    }
}
