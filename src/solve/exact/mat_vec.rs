//! The matrix–vector product of the exact propagator's inner loops (`Φ z` per segment, the
//! input terms of the Taylor series), shared by the transitions, the balanced series and the
//! crossing search.

/// `out = m · z` for a column-major `n × n` matrix (the single pair's augmented sizes
/// `3 + 2H` get a fixed-size, unrolled loop).
#[inline]
pub fn mat_vec(m: &[f64], z: &[f64], out: &mut [f64]) {
    match z.len() {
        3 => mat_vec_fixed::<3>(m, z, out),
        5 => mat_vec_fixed::<5>(m, z, out),
        7 => mat_vec_fixed::<7>(m, z, out),
        9 => mat_vec_fixed::<9>(m, z, out),
        _ => {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: the CPU has AVX (checked just above).
                unsafe { mat_vec_blocked_avx(m, z, out) };
                return;
            }
            mat_vec_blocked(m, z, out);
        }
    }
}

/// [`mat_vec_blocked`] compiled for AVX: four lanes per instruction instead of two. The same
/// multiplications and additions in the same order (no fused multiply-add), so the result is
/// bit for bit that of the baseline build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn mat_vec_blocked_avx(m: &[f64], z: &[f64], out: &mut [f64]) {
    mat_vec_blocked(m, z, out);
}

/// Rows up to which [`mat_vec_blocked`] holds blocks of rows in registers; a larger matrix
/// is streamed column by column instead (a block's pass reads every column at a stride of
/// `8n` bytes, one page per column or so once `n` is in the hundreds).
const BLOCKED_ROWS: usize = 64;

#[inline(always)]
fn mat_vec_blocked(m: &[f64], z: &[f64], out: &mut [f64]) {
    let n = z.len();
    let m = &m[..n * n];
    if n > BLOCKED_ROWS {
        out.fill(0.0);
        for (column, &zj) in m.chunks_exact(n).zip(z) {
            for (o, &mij) in out.iter_mut().zip(column) {
                *o += mij * zj;
            }
        }
        return;
    }
    // Blocks of eight rows, their sums held in registers across the columns (a running `out`
    // would be loaded and stored once per column).
    let mut row = 0;
    while row + 8 <= n {
        let mut acc = [0.0f64; 8];
        for (j, &zj) in z.iter().enumerate() {
            let column: &[f64; 8] = m[j * n + row..j * n + row + 8]
                .try_into()
                .expect("eight rows");
            for (a, &mij) in acc.iter_mut().zip(column) {
                *a += mij * zj;
            }
        }
        out[row..row + 8].copy_from_slice(&acc);
        row += 8;
    }
    if row < n {
        let rest = n - row;
        let mut acc = [0.0f64; 8];
        for (j, &zj) in z.iter().enumerate() {
            let column = &m[j * n + row..j * n + n];
            for (a, &mij) in acc[..rest].iter_mut().zip(column) {
                *a += mij * zj;
            }
        }
        out[row..].copy_from_slice(&acc[..rest]);
    }
}

#[inline(always)]
fn mat_vec_fixed<const N: usize>(m: &[f64], z: &[f64], out: &mut [f64]) {
    let m = &m[..N * N];
    let z: &[f64; N] = z.try_into().expect("vector of the matrix size");
    let mut acc = [0.0; N];
    for (j, &zj) in z.iter().enumerate() {
        for (i, a) in acc.iter_mut().enumerate() {
            *a += m[j * N + i] * zj;
        }
    }
    out[..N].copy_from_slice(&acc);
}
