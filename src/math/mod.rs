//! The bottom layer: small vector and tensor maths in `f64` and the seeded
//! hash every random choice draws from. It imports nothing from the crate.

mod noise;
mod tensor;
pub mod v3;

pub use noise::value_noise;
pub use tensor::{Sym2, Sym3};

/// A uniform value in [-1, 1] from `seed` and `key` (SplitMix64), the same
/// on every platform and thread count.
pub fn hash_unit(seed: u64, key: u64) -> f64 {
    let mut z = seed ^ key.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for _ in 0..2 {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    2.0 * ((z >> 11) as f64 / (1u64 << 53) as f64) - 1.0
}

/// Cholesky factorisation in place of the symmetric `m x m` row-major `a`
/// (its lower triangle is read and becomes the lower factor). A pivot at
/// most `1e-12` of the largest diagonal entry (or not a number) drops its
/// unknown: its column is zeroed and its entry in the result is `true`.
pub fn cholesky_dropping(a: &mut [f64], m: usize) -> Vec<bool> {
    let scale = (0..m).map(|i| a[i * m + i]).fold(0.0, f64::max);
    let mut dropped = vec![false; m];
    for j in 0..m {
        let mut d = a[j * m + j];
        for k in 0..j {
            d -= a[j * m + k] * a[j * m + k];
        }
        if d.is_nan() || d <= 1e-12 * scale {
            dropped[j] = true;
            for i in j..m {
                a[i * m + j] = 0.0;
            }
            continue;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let mut x = a[i * m + j];
            for k in 0..j {
                x -= a[i * m + k] * a[j * m + k];
            }
            a[i * m + j] = x / d;
        }
    }
    dropped
}
