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
        n => mat_vec_rows(m, z, 0..n, out),
    }
}

/// `out[rows] = m[rows, :] · z` for a column-major `n × n` matrix (`n = z.len()`): the rows
/// of `rows` only, each summed in ascending column order exactly as [`mat_vec`] sums it, so
/// the entries are bit for bit those of the whole product (the dense rows of a mode whose
/// other rows have few non-zeros: [`super::balanced::BalancedMatrix::times`]).
#[inline]
pub fn mat_vec_rows(m: &[f64], z: &[f64], rows: std::ops::Range<usize>, out: &mut [f64]) {
    strided_rows(m, z.len(), z, rows, out);
}

/// `out = m · z` for a column-major matrix of `out.len()` rows and `z.len()` columns (the
/// band of rows in which the modes of a system differ,
/// [`super::balanced::BandFrame`]), each row summed in ascending column order as
/// [`mat_vec`] sums it.
#[inline]
pub fn mat_vec_band(m: &[f64], z: &[f64], out: &mut [f64]) {
    let rows = out.len();
    strided_rows(m, rows, z, 0..rows, out);
}

/// `out[rows] = m[rows, :] · z` for a column-major matrix with columns of `stride` entries.
#[inline]
fn strided_rows(
    m: &[f64],
    stride: usize,
    z: &[f64],
    rows: std::ops::Range<usize>,
    out: &mut [f64],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX (checked just above).
        unsafe { rows_blocked_avx(m, stride, z, rows, out) };
        return;
    }
    rows_blocked(m, stride, z, rows, out);
}

/// [`rows_blocked`] compiled for AVX: four lanes per instruction instead of two. The same
/// multiplications and additions in the same order (no fused multiply-add), so the result is
/// bit for bit that of the baseline build.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn rows_blocked_avx(
    m: &[f64],
    stride: usize,
    z: &[f64],
    rows: std::ops::Range<usize>,
    out: &mut [f64],
) {
    rows_blocked(m, stride, z, rows, out);
}

/// The rows `rows` of the product of a column-major matrix with columns of `stride`
/// entries: blocks of rows in registers, or streamed column by column beyond
/// [`BLOCKED_ROWS`].
#[inline(always)]
fn rows_blocked(
    m: &[f64],
    stride: usize,
    z: &[f64],
    rows: std::ops::Range<usize>,
    out: &mut [f64],
) {
    let n = stride;
    let m = &m[..n * z.len()];
    if n > BLOCKED_ROWS {
        let out = &mut out[rows.clone()];
        out.fill(0.0);
        for (column, &zj) in m.chunks_exact(n).zip(z) {
            for (o, &mij) in out.iter_mut().zip(&column[rows.clone()]) {
                *o += mij * zj;
            }
        }
        return;
    }
    // Blocks of sixteen rows, their sums held in registers across the columns (a running
    // `out` would be loaded and stored once per column): four independent chains of vector
    // additions per column rather than the two of eight rows, whose add latency bounded the
    // pass. The rows left go by eight, four and one to three, in registers too. Every row
    // sums its products in ascending column order whatever its block, so the result does
    // not depend on the blocking.
    let mut row = rows.start;
    while row + 16 <= rows.end {
        rows_block::<16>(m, n, z, row, out);
        row += 16;
    }
    if row + 8 <= rows.end {
        rows_block::<8>(m, n, z, row, out);
        row += 8;
    }
    if row + 4 <= rows.end {
        rows_block::<4>(m, n, z, row, out);
        row += 4;
    }
    match rows.end - row {
        1 => rows_block::<1>(m, n, z, row, out),
        2 => rows_block::<2>(m, n, z, row, out),
        3 => rows_block::<3>(m, n, z, row, out),
        _ => {}
    }
}

/// Rows up to which [`rows_blocked`] holds blocks of rows in registers; a larger matrix
/// is streamed column by column instead (a block's pass reads every column at a stride of
/// `8n` bytes, one page per column or so once `n` is in the hundreds).
const BLOCKED_ROWS: usize = 128;

/// `out[row..row + R] = m[row..row + R, :] · z`, the `R` sums in registers (columns of
/// `stride` entries).
#[inline(always)]
fn rows_block<const R: usize>(m: &[f64], stride: usize, z: &[f64], row: usize, out: &mut [f64]) {
    let mut acc = [0.0f64; R];
    for (column, &zj) in m.chunks_exact(stride).zip(z) {
        let column: &[f64; R] = column[row..row + R].try_into().expect("R rows");
        for (a, &mij) in acc.iter_mut().zip(column) {
            *a += mij * zj;
        }
    }
    out[row..row + R].copy_from_slice(&acc);
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

#[cfg(test)]
mod tests {
    use super::{mat_vec, mat_vec_band, mat_vec_rows};

    /// Every size from 1 to past the streamed ones against the plain sums, row by row in
    /// ascending column order, bit for bit (the blocking only changes which sums share a
    /// register; the single pair's fixed sizes, the blocks of 16, 8, 4 and 1–3 rows and the
    /// streamed matrices all sum each row in the same order).
    #[test]
    fn every_size_matches_the_plain_row_sums_exactly() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for n in (1..=70).chain([127, 128, 129, 140]) {
            let m: Vec<f64> = (0..n * n)
                .map(|_| next() * 10f64.powi((next() * 6.0) as i32))
                .collect();
            let z: Vec<f64> = (0..n).map(|_| next()).collect();
            let mut out = vec![f64::NAN; n];
            mat_vec(&m, &z, &mut out);
            for i in 0..n {
                let mut sum = 0.0;
                for j in 0..n {
                    sum += m[j * n + i] * z[j];
                }
                assert_eq!(out[i].to_bits(), sum.to_bits(), "n = {n}, row {i}");
            }
            // A band of rows stored alone (columns of the band's height): the same bits.
            for (start, end) in [(0, n), (n / 3, n / 3 + n / 2 + 1), (n - 1, n)] {
                let end = end.min(n);
                let band: Vec<f64> = (0..n)
                    .flat_map(|j| m[j * n + start..j * n + end].iter().copied())
                    .collect();
                let mut part = vec![f64::NAN; end - start];
                mat_vec_band(&band, &z, &mut part);
                for (i, p) in (start..end).zip(&part) {
                    assert_eq!(p.to_bits(), out[i].to_bits(), "n = {n}, band row {i}");
                }
            }
            // Every range of rows of the same matrix: the same bits, nothing else written.
            for (start, end) in [(0, n), (0, n / 2), (n / 3, n), (n / 4, n / 4 + n / 2 + 1)] {
                let end = end.min(n);
                let mut part = vec![f64::NAN; n];
                mat_vec_rows(&m, &z, start..end, &mut part);
                for i in 0..n {
                    if (start..end).contains(&i) {
                        assert_eq!(part[i].to_bits(), out[i].to_bits(), "n = {n}, row {i}");
                    } else {
                        assert!(part[i].is_nan(), "n = {n}, row {i} written");
                    }
                }
            }
        }
    }
}
