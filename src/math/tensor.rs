//! Small symmetric tensors in `f64`.
//!
//! Element stress is stored as a symmetric 3x3 *tangent* tensor in world space
//! (`E sigma E^T` for the element's tangent frame `E`), so a triangle split by
//! remeshing hands its stress to its children without re-expressing frames.
//! [`Sym2`] is the same stress in an element's own 2D frame.

use super::v3;
use std::ops::{Add, AddAssign, Mul, Sub};

/// A symmetric 2x2 tensor `[[xx, xy], [xy, yy]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym2 {
    /// Component xx.
    pub xx: f64,
    /// Component yy.
    pub yy: f64,
    /// Component xy (= yx).
    pub xy: f64,
}

impl Sym2 {
    /// Eigenvalues (ascending) and unit eigenvectors, in closed form.
    pub fn eigen(&self) -> ([f64; 2], [[f64; 2]; 2]) {
        let m = 0.5 * (self.xx + self.yy);
        let d = 0.5 * (self.xx - self.yy);
        let r = d.hypot(self.xy);
        let (l0, l1) = (m - r, m + r);
        // Eigenvector of the larger eigenvalue: angle theta with tan(2 theta) = 2xy / (xx - yy).
        let theta = 0.5 * self.xy.atan2(d);
        let (s, c) = theta.sin_cos();
        ([l0, l1], [[-s, c], [c, s]])
    }
}

/// A symmetric 3x3 tensor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym3 {
    /// Component xx.
    pub xx: f64,
    /// Component yy.
    pub yy: f64,
    /// Component zz.
    pub zz: f64,
    /// Component xy.
    pub xy: f64,
    /// Component xz.
    pub xz: f64,
    /// Component yz.
    pub yz: f64,
}

impl Sym3 {
    /// The zero tensor.
    pub const ZERO: Sym3 = Sym3 {
        xx: 0.0,
        yy: 0.0,
        zz: 0.0,
        xy: 0.0,
        xz: 0.0,
        yz: 0.0,
    };

    /// The identity.
    pub const IDENTITY: Sym3 = Sym3 {
        xx: 1.0,
        yy: 1.0,
        zz: 1.0,
        xy: 0.0,
        xz: 0.0,
        yz: 0.0,
    };

    /// `v v^T`.
    pub fn outer(v: [f64; 3]) -> Sym3 {
        Sym3 {
            xx: v[0] * v[0],
            yy: v[1] * v[1],
            zz: v[2] * v[2],
            xy: v[0] * v[1],
            xz: v[0] * v[2],
            yz: v[1] * v[2],
        }
    }

    /// `(a b^T + b a^T) / 2`.
    pub fn sym_outer(a: [f64; 3], b: [f64; 3]) -> Sym3 {
        Sym3 {
            xx: a[0] * b[0],
            yy: a[1] * b[1],
            zz: a[2] * b[2],
            xy: 0.5 * (a[0] * b[1] + a[1] * b[0]),
            xz: 0.5 * (a[0] * b[2] + a[2] * b[0]),
            yz: 0.5 * (a[1] * b[2] + a[2] * b[1]),
        }
    }

    /// The paper's `m(v) = v v^T / |v|`, with `m(0) = 0`.
    pub fn m(v: [f64; 3]) -> Sym3 {
        let n = v3::norm(v);
        if n > 0.0 && n.is_finite() {
            Sym3::outer(v) * (1.0 / n)
        } else {
            Sym3::ZERO
        }
    }

    /// The in-plane tensor `c (I - n n^T)` for a unit normal `n`.
    pub fn tangent_identity(n: [f64; 3], c: f64) -> Sym3 {
        (Sym3::IDENTITY - Sym3::outer(n)) * c
    }

    /// `S v`.
    pub fn mul_vec(&self, v: [f64; 3]) -> [f64; 3] {
        [
            self.xx * v[0] + self.xy * v[1] + self.xz * v[2],
            self.xy * v[0] + self.yy * v[1] + self.yz * v[2],
            self.xz * v[0] + self.yz * v[1] + self.zz * v[2],
        ]
    }

    /// `a^T S b`.
    pub fn quad(&self, a: [f64; 3], b: [f64; 3]) -> f64 {
        v3::dot(a, self.mul_vec(b))
    }

    /// Squared Frobenius norm.
    pub fn frobenius_sq(&self) -> f64 {
        self.xx * self.xx
            + self.yy * self.yy
            + self.zz * self.zz
            + 2.0 * (self.xy * self.xy + self.xz * self.xz + self.yz * self.yz)
    }

    /// Trace.
    pub fn trace(&self) -> f64 {
        self.xx + self.yy + self.zz
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        [self.xx, self.yy, self.zz, self.xy, self.xz, self.yz]
            .iter()
            .all(|x| x.is_finite())
    }

    /// The 2D tensor `E^T S E` in the frame with unit axes `e1`, `e2`.
    pub fn to_frame(self, e1: [f64; 3], e2: [f64; 3]) -> Sym2 {
        Sym2 {
            xx: self.quad(e1, e1),
            yy: self.quad(e2, e2),
            xy: self.quad(e1, e2),
        }
    }

    /// The world tensor `E s E^T` of a 2D tensor in the frame `e1`, `e2`.
    pub fn from_frame(s: &Sym2, e1: [f64; 3], e2: [f64; 3]) -> Sym3 {
        Sym3::outer(e1) * s.xx + Sym3::outer(e2) * s.yy + Sym3::sym_outer(e1, e2) * (2.0 * s.xy)
    }

    /// Eigenvalues (ascending) and unit eigenvectors (columns of the returned
    /// array, `vectors[k]` for `values[k]`), by nalgebra's symmetric solver.
    pub fn eigen(&self) -> ([f64; 3], [[f64; 3]; 3]) {
        let m = nalgebra::Matrix3::new(
            self.xx, self.xy, self.xz, self.xy, self.yy, self.yz, self.xz, self.yz, self.zz,
        );
        let e = nalgebra::SymmetricEigen::new(m);
        let mut idx = [0usize, 1, 2];
        idx.sort_by(|&a, &b| e.eigenvalues[a].total_cmp(&e.eigenvalues[b]));
        let values = idx.map(|k| e.eigenvalues[k]);
        let vectors = idx.map(|k| {
            let c = e.eigenvectors.column(k);
            [c[0], c[1], c[2]]
        });
        (values, vectors)
    }

    /// The largest eigenvalue and its unit eigenvector.
    pub fn max_eigen(&self) -> (f64, [f64; 3]) {
        let (v, e) = self.eigen();
        (v[2], e[2])
    }
}

impl Add for Sym3 {
    type Output = Sym3;
    fn add(self, o: Sym3) -> Sym3 {
        Sym3 {
            xx: self.xx + o.xx,
            yy: self.yy + o.yy,
            zz: self.zz + o.zz,
            xy: self.xy + o.xy,
            xz: self.xz + o.xz,
            yz: self.yz + o.yz,
        }
    }
}

impl Sub for Sym3 {
    type Output = Sym3;
    fn sub(self, o: Sym3) -> Sym3 {
        self + o * -1.0
    }
}

impl AddAssign for Sym3 {
    fn add_assign(&mut self, o: Sym3) {
        *self = *self + o;
    }
}

impl Mul<f64> for Sym3 {
    type Output = Sym3;
    fn mul(self, s: f64) -> Sym3 {
        Sym3 {
            xx: self.xx * s,
            yy: self.yy * s,
            zz: self.zz * s,
            xy: self.xy * s,
            xz: self.xz * s,
            yz: self.yz * s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn sym2_eigen_matches_nalgebra() {
        let mut s = 7;
        for _ in 0..1000 {
            let t = Sym2 {
                xx: lcg(&mut s),
                yy: lcg(&mut s),
                xy: lcg(&mut s),
            };
            let (vals, vecs) = t.eigen();
            let m = nalgebra::Matrix2::new(t.xx, t.xy, t.xy, t.yy);
            let mut ref_vals: Vec<f64> = nalgebra::SymmetricEigen::new(m)
                .eigenvalues
                .iter()
                .copied()
                .collect();
            ref_vals.sort_by(f64::total_cmp);
            for k in 0..2 {
                assert!((vals[k] - ref_vals[k]).abs() < 1e-12, "{t:?}");
                let v = vecs[k];
                let mv = [t.xx * v[0] + t.xy * v[1], t.xy * v[0] + t.yy * v[1]];
                assert!(
                    (mv[0] - vals[k] * v[0]).abs() < 1e-12
                        && (mv[1] - vals[k] * v[1]).abs() < 1e-12
                );
                assert!((v[0].hypot(v[1]) - 1.0).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn sym3_eigen_is_an_eigendecomposition() {
        let mut s = 11;
        for _ in 0..200 {
            let t = Sym3 {
                xx: lcg(&mut s),
                yy: lcg(&mut s),
                zz: lcg(&mut s),
                xy: lcg(&mut s),
                xz: lcg(&mut s),
                yz: lcg(&mut s),
            };
            let (vals, vecs) = t.eigen();
            assert!(vals[0] <= vals[1] && vals[1] <= vals[2]);
            for k in 0..3 {
                let mv = t.mul_vec(vecs[k]);
                for c in 0..3 {
                    assert!((mv[c] - vals[k] * vecs[k][c]).abs() < 1e-10);
                }
            }
        }
    }

    #[test]
    fn frame_round_trip_and_m() {
        let e1 = [1.0 / 2f64.sqrt(), 1.0 / 2f64.sqrt(), 0.0];
        let e2 = [0.0, 0.0, 1.0];
        let s = Sym2 {
            xx: 2.0,
            yy: -1.0,
            xy: 0.5,
        };
        let w = Sym3::from_frame(&s, e1, e2);
        let back = w.to_frame(e1, e2);
        assert!(
            (back.xx - 2.0).abs() < 1e-14
                && (back.yy + 1.0).abs() < 1e-14
                && (back.xy - 0.5).abs() < 1e-14
        );
        assert_eq!(Sym3::m([0.0; 3]), Sym3::ZERO);
        let m = Sym3::m([3.0, 4.0, 0.0]);
        assert!((m.trace() - 5.0).abs() < 1e-14, "trace of m(v) is |v|");
    }
}
