//! Byte layout of the drivetrain model's part of an FMU state (FMI 2.0.x §2.1.8). The FMI
//! layer wraps it in its versioned, checksummed envelope ([`crate::fmi::blob`]); this module
//! only turns a [`TrainSnapshot`] into bytes and back, rejecting anything malformed.
//!
//! Layout, little-endian: tag `"GDTR"` and `u32` format version (so a single-mesh payload,
//! which starts with its parameter count, is never read as a drivetrain one), `u32 n` then
//! `n × (u32 vr, f64 value)`, `u8 flags` (bit 0 initialized, bit 1 RK controller present,
//! bit 2 controller step proposal present, bit 3 last step rejected, bit 4 torque rates
//! present, bit 5 speed-port neighbours present, bit 6 input derivatives of orders 2–3
//! present), `f64` start time, t, the three inputs, loss start; with bit 4 `f64` input and
//! load torque rates and the time they start from (`fmi2SetRealInputDerivatives`; held
//! torques write no bit and no bytes, so such states keep the version-1 bytes); with bit 5
//! `u32 n` and `n × f64` angle, speed, angle rate, speed rate, anchor, the ended ramp's two
//! rates of each speed port's neighbour (input port first); with bit 6 `4 × f64` the input
//! and load torques' derivatives of orders 2 and 3 (`T''_in, T'''_in, T''_load, T'''_load`)
//! and, per neighbour of bit 5, `4 × f64` `φ'', φ''', ω'', ω'''` (only a state saved between
//! setting orders 2–3 and the step has the bit: states without it, older ones included,
//! read these as 0); `u32 dim` and `dim × f64` state; `u32` meshes, each
//! `f64` clock t0, p0, f, cycle, loss total, `u8` loss-since present, `f64` loss since,
//! `u64` interval, `u32` slots and `slots × u8` flag codes; for RK `f64` proposal, `f64`
//! previous error, `u32` non-finite trials.

use crate::fmi::bytes::{put_f64s, Reader};
use crate::fmu::payload::{
    controller_bits, put_controller, put_params, read_controller, read_params, Snapshot,
};
use crate::model::train::{
    MeshRunState, Neighbour, SlotContact, TrainInputs, TrainRunState, TrainSimState,
};
use crate::model::PhaseClock;

const TAG: &[u8; 4] = b"GDTR";
/// Bumped whenever the layout above changes.
pub const FORMAT_VERSION: u32 = 1;

/// Everything the drivetrain model needs to continue bit-identically.
pub type TrainSnapshot = Snapshot<TrainSimState>;

pub fn encode(s: &TrainSnapshot) -> Vec<u8> {
    // Sized once, parameters included (a master saves a state before every step).
    let mut out = Vec::with_capacity(256 + 12 * s.params.len() + 8 * s.sim.y.len());
    out.extend_from_slice(TAG);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    put_params(&mut out, &s.params);
    let c = s.sim.controller;
    let tr = &s.sim.train;
    let rates = tr.torque_rates != [0.0; 2];
    let neighbours = !tr.neighbours.is_empty();
    let higher =
        tr.torque_higher != [[0.0; 2]; 2] || tr.neighbours.iter().any(|n| n.higher != [0.0; 4]);
    out.push(
        u8::from(s.initialized)
            | controller_bits(c) << 1
            | u8::from(rates) << 4
            | u8::from(neighbours) << 5
            | u8::from(higher) << 6,
    );
    let u = tr.inputs;
    put_f64s(
        &mut out,
        &[
            s.start_time,
            s.sim.t,
            u.input_speed,
            u.input_torque,
            u.load_torque,
            tr.loss_start,
        ],
    );
    if rates {
        put_f64s(
            &mut out,
            &[tr.torque_rates[0], tr.torque_rates[1], tr.torque_anchor],
        );
    }
    if neighbours {
        out.extend_from_slice(&(tr.neighbours.len() as u32).to_le_bytes());
        for n in &tr.neighbours {
            put_f64s(
                &mut out,
                &[
                    n.angle,
                    n.speed,
                    n.angle_rate,
                    n.speed_rate,
                    n.anchor,
                    n.ended[0],
                    n.ended[1],
                ],
            );
        }
    }
    if higher {
        let h = tr.torque_higher;
        put_f64s(&mut out, &[h[0][0], h[0][1], h[1][0], h[1][1]]);
        for n in &tr.neighbours {
            put_f64s(&mut out, &n.higher);
        }
    }
    out.extend_from_slice(&(s.sim.y.len() as u32).to_le_bytes());
    put_f64s(&mut out, &s.sim.y);
    out.extend_from_slice(&(tr.meshes.len() as u32).to_le_bytes());
    for m in &tr.meshes {
        let (t0, p0) = m.clock.anchor();
        put_f64s(
            &mut out,
            &[t0, p0, m.clock.mesh_frequency(), m.cycle, m.loss_total],
        );
        out.push(u8::from(m.loss_since.is_some()));
        put_f64s(&mut out, &[m.loss_since.unwrap_or(0.0)]);
        out.extend_from_slice(&(m.interval as u64).to_le_bytes());
        out.extend_from_slice(&(m.flags.len() as u32).to_le_bytes());
        out.extend(m.flags.iter().map(|f| f.code()));
    }
    put_controller(&mut out, c);
    out
}

/// A count read from the payload, bounded by what the remaining bytes can hold (a corrupt
/// count is an error, not a huge allocation).
fn count(r: &mut Reader, what: &str, bytes_each: usize) -> Result<usize, String> {
    let n = r.u32()? as usize;
    if n > r.remaining() / bytes_each {
        return Err(format!(
            "drivetrain state lists {n} {what} in {} remaining bytes",
            r.remaining()
        ));
    }
    Ok(n)
}

pub fn decode(bytes: &[u8]) -> Result<TrainSnapshot, String> {
    let mut r = Reader::new(bytes);
    let tag = r.take(4).map_err(|_| "model state too short".to_string())?;
    if tag != TAG {
        return Err(format!(
            "model state is not a drivetrain state (tag {tag:02x?}, expected \"GDTR\"): \
             a state of another model kind"
        ));
    }
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "drivetrain state format version {version} is not supported (expected {FORMAT_VERSION})"
        ));
    }
    let n = count(&mut r, "parameters", 12)?;
    let params = read_params(&mut r, n)?;
    let flags = r.u8()?;
    if flags & !0b111_1111 != 0 {
        return Err(format!("drivetrain state has unknown flags {flags:#04x}"));
    }
    let mut f = [0.0; 6];
    for x in &mut f {
        *x = r.f64()?;
    }
    let mut rates = [0.0; 3];
    if flags & 0b1_0000 != 0 {
        for x in &mut rates {
            *x = r.f64()?;
        }
    }
    let mut neighbours = Vec::new();
    if flags & 0b10_0000 != 0 {
        for _ in 0..count(&mut r, "speed-port neighbours", 56)? {
            let mut v = [0.0; 7];
            for x in &mut v {
                *x = r.f64()?;
            }
            let [angle, speed, angle_rate, speed_rate, anchor, e0, e1] = v;
            neighbours.push(Neighbour {
                angle,
                speed,
                angle_rate,
                speed_rate,
                anchor,
                ended: [e0, e1],
                higher: [0.0; 4],
            });
        }
    }
    let mut torque_higher = [[0.0; 2]; 2];
    if flags & 0b100_0000 != 0 {
        for x in torque_higher.as_flattened_mut() {
            *x = r.f64()?;
        }
        for n in &mut neighbours {
            for x in &mut n.higher {
                *x = r.f64()?;
            }
        }
    }
    let dim = count(&mut r, "state entries", 8)?;
    let y = (0..dim).map(|_| r.f64()).collect::<Result<Vec<_>, _>>()?;
    let meshes = count(&mut r, "meshes", 61)?;
    let mut ms = Vec::with_capacity(meshes);
    for n in 0..meshes {
        let mut g = [0.0; 5];
        for x in &mut g {
            *x = r.f64()?;
        }
        let has_since = r.u8()?;
        let since = r.f64()?;
        let interval = r.u64()?;
        let slots = count(&mut r, "slots", 1)?;
        let flags = r
            .take(slots)?
            .iter()
            .map(|&c| {
                SlotContact::from_code(c)
                    .ok_or_else(|| format!("mesh {n}: contact flag code {c} does not exist"))
            })
            .collect::<Result<Vec<_>, _>>()?;
        ms.push(MeshRunState {
            clock: PhaseClock::new(g[0], g[1], g[2]),
            cycle: g[3],
            interval: usize::try_from(interval)
                .map_err(|_| format!("mesh {n}: interval {interval}"))?,
            flags,
            loss_total: g[4],
            loss_since: match has_since {
                0 => None,
                1 => Some(since),
                b => return Err(format!("mesh {n}: loss flag {b} is not 0 or 1")),
            },
        });
    }
    let controller = read_controller(&mut r, (flags >> 1) & 0b111)?;
    r.finish("drivetrain state")?;
    Ok(TrainSnapshot {
        params,
        start_time: f[0],
        initialized: flags & 1 != 0,
        extra: (),
        sim: TrainSimState {
            t: f[1],
            y,
            train: TrainRunState {
                inputs: TrainInputs {
                    input_speed: f[2],
                    input_torque: f[3],
                    load_torque: f[4],
                },
                loss_start: f[5],
                meshes: ms,
                torque_rates: [rates[0], rates[1]],
                torque_anchor: rates[2],
                torque_higher,
                neighbours,
            },
            controller,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::rk::ControllerMemory;

    fn sample(controller: Option<ControllerMemory>) -> TrainSnapshot {
        let mesh = |k: f64| MeshRunState {
            clock: PhaseClock::new(0.1 * k, 3.25 + k, 2000.0 / k),
            cycle: 3.0 + k,
            interval: 2,
            flags: vec![
                SlotContact::Drive,
                SlotContact::Inactive,
                SlotContact::Back,
                SlotContact::Wedged,
            ],
            loss_total: 1e-4 * k,
            loss_since: (k > 1.0).then_some(0.0125),
        };
        TrainSnapshot {
            params: vec![(0, 0.02), (1000, 0.5), (31, -1.25)],
            start_time: 0.5,
            initialized: true,
            extra: (),
            sim: TrainSimState {
                t: 0.125,
                y: vec![1e-6, -2e-3, 3.0, 4.5],
                train: TrainRunState {
                    inputs: TrainInputs {
                        input_speed: 330.0,
                        input_torque: 100.0,
                        load_torque: 247.0,
                    },
                    loss_start: 0.01,
                    meshes: vec![mesh(1.0), mesh(2.0)],
                    torque_rates: if controller.is_some() {
                        [250.0, -1.5]
                    } else {
                        [0.0; 2]
                    },
                    torque_anchor: if controller.is_some() { 0.125 } else { 0.0 },
                    torque_higher: if controller.is_some() {
                        [[4.0e4, -2.5e6], [0.0, 7.0]]
                    } else {
                        [[0.0; 2]; 2]
                    },
                    neighbours: if controller.is_some() {
                        vec![Neighbour {
                            angle: 0.005,
                            speed: 471.0,
                            angle_rate: 471.5,
                            speed_rate: -30.0,
                            anchor: 0.125,
                            ended: [470.0, 12.5],
                            higher: [-3.0e3, 0.0, 1.5e4, -8.0e5],
                        }]
                    } else {
                        Vec::new()
                    },
                },
                controller,
            },
        }
    }

    #[test]
    fn round_trip_and_malformed_payloads() {
        let b = crate::fmu::payload::check_layout(sample, encode, decode);
        let mut version = b.clone();
        version[4] = 2;
        assert!(decode(&version).unwrap_err().contains("version 2"));
        let mut huge = b;
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge).unwrap_err().contains("parameters"));
    }

    #[test]
    fn a_single_mesh_payload_is_not_a_drivetrain_state() {
        // Oracle: the single-mesh layout (`crate::fmu::pair`) written by its own encoder.
        let single = crate::fmu::pair::state::encode(&crate::fmu::pair::state::sample(None));
        let e = decode(&single).unwrap_err();
        assert!(e.contains("not a drivetrain state"), "{e}");
        // And the other way round: the single-mesh reader refuses a drivetrain payload.
        assert!(crate::fmu::pair::state::decode(&encode(&sample(None))).is_err());
    }
}
