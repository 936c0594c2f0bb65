//! [`BalancedMatrix::new`] against the dense Parlett–Reinsch sweeps it replaces (every
//! entry of every column and row, as LAPACK `gebal` and this crate's balancing before it read
//! only the non-zeros): the same `D`, `B` and `‖B‖₁` bit for bit, and [`BalancedMatrix::times`]
//! the plain row sums of that `B`; and the modes of a band frame against `D⁻¹AD` of their
//! frame's `D`.

use nalgebra::DMatrix;

use super::balanced::BalancedMatrix;

/// The dense balancing (Parlett & Reinsch 1969, with `gebal`'s under/overflow guards): `D`,
/// `B = D⁻¹ A D` and `‖B‖₁`, every sum over the whole column or row.
fn dense_balance(a: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>, f64) {
    let n = a.nrows();
    let mut b = a.clone();
    let mut scale = vec![1.0f64; n];
    for _sweep in 0..32 {
        let mut converged = true;
        for i in 0..n {
            let (mut c, mut r) = (0.0f64, 0.0f64);
            for j in 0..n {
                if j != i {
                    c += b[(j, i)].abs();
                    r += b[(i, j)].abs();
                }
            }
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let mut f = 1.0f64;
            let (mut cc, mut rr) = (c, r);
            let (low, high) = (4.0 * f64::MIN_POSITIVE, f64::MAX / 4.0);
            while cc < rr / 2.0 && rr > low && cc < high {
                cc *= 2.0;
                rr /= 2.0;
                f *= 2.0;
            }
            while cc >= rr * 2.0 && cc > low && rr < high {
                cc /= 2.0;
                rr *= 2.0;
                f /= 2.0;
            }
            if (cc + rr) < 0.95 * (c + r) {
                converged = false;
                scale[i] *= f;
                for j in 0..n {
                    b[(j, i)] *= f;
                    b[(i, j)] /= f;
                }
            }
        }
        if converged {
            break;
        }
    }
    let norm = (0..n)
        .map(|j| b.column(j).iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    (scale, b, norm)
}

/// A xorshift generator of uniform numbers in `[0, 1)`.
fn uniform(seed: &mut u64) -> f64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

/// A sparse matrix of a gear mode's kind: entries of random sign over `10^±spread`, a
/// density of `density`, a band of dense rows, some empty rows and columns, and with
/// `extreme` a few entries near the ends of the double range (the guards, underflow to zero).
fn sparse_matrix(
    n: usize,
    density: f64,
    spread: f64,
    extreme: bool,
    seed: &mut u64,
) -> DMatrix<f64> {
    let dense_from = n / 3;
    let dense_to = dense_from + n / 5;
    let empty = |k: usize| n > 6 && k % 7 == 3;
    DMatrix::from_fn(n, n, |i, j| {
        let take = if (dense_from..dense_to).contains(&i) {
            uniform(seed) < 0.9
        } else {
            uniform(seed) < density
        };
        if !take || (i != j && (empty(i) || empty(j + 1))) {
            return 0.0;
        }
        let sign = if uniform(seed) < 0.5 { -1.0 } else { 1.0 };
        let magnitude = 10f64.powf((uniform(seed) * 2.0 - 1.0) * spread);
        let value = sign * magnitude;
        if extreme && uniform(seed) < 0.02 {
            if uniform(seed) < 0.5 {
                value * 1e-300
            } else {
                value * 1e290
            }
        } else {
            value
        }
    })
}

/// `balanced.times(u)` for a random `u` is the plain row sums of `b`, bit for bit.
fn assert_times_is_the_plain_row_sums(balanced: &BalancedMatrix, b: &DMatrix<f64>, seed: &mut u64) {
    let n = b.nrows();
    let u: Vec<f64> = (0..n).map(|_| uniform(seed) - 0.5).collect();
    let mut out = vec![f64::NAN; n];
    balanced.times(&u, &mut out);
    for (i, &o) in out.iter().enumerate() {
        let sum = (0..n).fold(0.0, |s, j| s + b[(i, j)] * u[j]);
        assert_eq!(o.to_bits(), sum.to_bits(), "B u, n = {n}, row {i}");
    }
}

#[test]
fn the_sparse_sweeps_give_the_dense_balancing_bit_for_bit() {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut cases = 0;
    for n in (1..=40).chain([51, 65, 67, 133]) {
        for (density, spread, extreme) in [
            (0.05, 3.0, false),
            (0.2, 10.0, false),
            (0.5, 6.0, true),
            (1.0, 2.0, false),
        ] {
            let a = sparse_matrix(n, density, spread, extreme, &mut seed);
            let balanced = BalancedMatrix::new(&a);
            let (scale, b, norm) = dense_balance(&a);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(balanced.scale()),
                bits(&scale),
                "D, n = {n}, {density}"
            );
            assert_eq!(
                bits(balanced.matrix().as_slice()),
                bits(b.as_slice()),
                "B, n = {n}, {density}"
            );
            assert_eq!(balanced.norm().to_bits(), norm.to_bits(), "‖B‖₁, n = {n}");
            // The product by rows (sparse rows compressed, dense rows blocked) against the
            // plain row sums of the dense `B`.
            assert_times_is_the_plain_row_sums(&balanced, &b, &mut seed);
            cases += 1;
        }
    }
    assert_eq!(cases, 44 * 4);
}

#[test]
fn a_matrix_with_a_non_finite_entry_is_left_as_it_is() {
    let mut a = DMatrix::from_fn(9, 9, |i, j| (i * 9 + j) as f64 - 40.0);
    a[(4, 7)] = f64::NAN;
    let balanced = BalancedMatrix::new(&a);
    assert!(balanced.norm().is_infinite());
    assert_eq!(balanced.scale(), &[1.0; 9]);
    assert_eq!(balanced.matrix()[(2, 3)], a[(2, 3)]);
}

/// The modes of a [`BandFrame`]: matrices that share every row outside a band, balanced by
/// the `D` of their envelope `max |A|`. Each mode's `B` is `D⁻¹ A D` bit for bit, its
/// product by rows the plain row sums of that `B`, its `A` recovered exactly, its `‖B‖₁` the
/// column sums of its `B`, and its exponential that of the mode balanced on its own; a mode
/// far outside the envelope, or with an entry that is not finite, is refused.
#[test]
fn a_band_frame_balances_every_mode_of_its_rows_exactly() {
    use super::balanced::BandFrame;
    use std::sync::Arc;
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for n in [2, 5, 9, 33, 65, 129] {
        let band = n / 3..(n / 3 + n / 4).max(n / 3 + 1);
        let base = sparse_matrix(n, 0.2, 4.0, false, &mut seed);
        // Modes: the band rows dense and random, some entries dropped (a lost contact).
        let modes: Vec<DMatrix<f64>> = (0..6)
            .map(|_| {
                let mut a = base.clone();
                for i in band.clone() {
                    for j in 0..n {
                        a[(i, j)] = if uniform(&mut seed) < 0.2 {
                            0.0
                        } else {
                            (uniform(&mut seed) - 0.5) * 10f64.powf(uniform(&mut seed) * 4.0)
                        };
                    }
                }
                a
            })
            .collect();
        let envelope = (modes.iter()).fold(DMatrix::<f64>::zeros(n, n), |e, a| {
            e.zip_map(a, |x: f64, y: f64| x.max(y.abs()))
        });
        let frame = Arc::new(
            BandFrame::of(&modes[0], &BalancedMatrix::new(&envelope), band.clone())
                .expect("a finite envelope"),
        );
        let d = BalancedMatrix::new(&envelope).scale().to_vec();
        let h = band.len();
        for a in &modes {
            let rows: Vec<f64> = (0..n)
                .flat_map(|j| band.clone().map(move |i| (i, j)))
                .map(|(i, j)| a[(i, j)])
                .collect();
            assert_eq!(rows.len(), h * n);
            let balanced = frame.balance(rows).expect("a mode within the envelope");
            assert!(balanced.in_band_frame());
            assert_eq!(bits(balanced.scale()), bits(&d), "D, n = {n}");
            let b = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * (d[j] / d[i]));
            assert_eq!(
                bits(balanced.matrix().as_slice()),
                bits(b.as_slice()),
                "B, n = {n}"
            );
            assert_eq!(
                bits(balanced.unbalanced().as_slice()),
                bits(a.as_slice()),
                "A, n = {n}"
            );
            let norm = (0..n)
                .map(|j| b.column(j).iter().map(|x| x.abs()).sum::<f64>())
                .fold(0.0, f64::max);
            assert!(
                (balanced.norm() - norm).abs() <= 1e-14 * norm,
                "‖B‖₁ {} against {norm}, n = {n}",
                balanced.norm()
            );
            assert_times_is_the_plain_row_sums(&balanced, &b, &mut seed);
            let tau = 0.5 / norm;
            let (x, y) = (balanced.exp(tau), BalancedMatrix::new(a).exp(tau));
            let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = (&x - &y).iter().fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(
                diff <= 1e-12 * scale,
                "e^(Aτ), n = {n}: {diff:e} of {scale:e}"
            );
        }
        // Far outside the envelope, or not finite: refused.
        let mut far: Vec<f64> = (0..n)
            .flat_map(|j| band.clone().map(move |i| (i, j)))
            .map(|(i, j)| modes[0][(i, j)])
            .collect();
        let mut nan = far.clone();
        far[h * (n - 1)] = 1e300;
        assert!(frame.balance(far).is_none(), "n = {n}");
        nan[0] = f64::NAN;
        assert!(frame.balance(nan).is_none(), "n = {n}");
    }
}
