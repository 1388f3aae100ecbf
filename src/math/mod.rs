//! The bottom layer: small vector and tensor maths in `f64` and the seeded
//! hash every random choice draws from (and the growth rule of the large
//! arrays that follow a mesh). It imports nothing from the crate.

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

/// Growth for the large arrays that follow a mesh (per node, face or
/// corner): when an array needs more room it takes what it needs and a
/// sixteenth more (at least 64), so an array growing a few faces at a time holds at most
/// about 6% unused, where `Vec`'s own doubling can leave up to half of a
/// large array's memory unused at the run's peak.
pub trait GrowGently<T> {
    /// Make room for `len` elements in all.
    fn reserve_gently(&mut self, len: usize);
    /// [`Vec::resize`] after [`GrowGently::reserve_gently`].
    fn resize_gently(&mut self, len: usize, value: T)
    where
        T: Clone;
}

impl<T> GrowGently<T> for Vec<T> {
    fn reserve_gently(&mut self, len: usize) {
        if self.capacity() < len {
            self.reserve_exact(len - self.len() + (len / 16).max(64));
        }
    }

    fn resize_gently(&mut self, len: usize, value: T)
    where
        T: Clone,
    {
        self.reserve_gently(len);
        self.resize(len, value);
    }
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

#[cfg(test)]
mod tests {
    use super::GrowGently;

    /// Grown one element at a time to a million, an array never holds
    /// more than a sixteenth (or 64) unused, and it is moved only about
    /// 130 times (each move takes a sixteenth more).
    #[test]
    fn arrays_grow_by_a_sixteenth() {
        let mut v: Vec<u64> = Vec::new();
        let mut moves = 0;
        for i in 0..1_000_000u64 {
            let cap = v.capacity();
            v.resize_gently(v.len() + 1, i);
            if v.capacity() != cap {
                moves += 1;
            }
            assert!(v.capacity() <= v.len() + (v.len() / 16).max(64), "{} of {}", v.capacity(), v.len());
        }
        assert!((100..=160).contains(&moves), "{moves} moves");
        assert_eq!(v[999_999], 999_999);
    }
}
