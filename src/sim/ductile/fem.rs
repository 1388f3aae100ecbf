//! Corotational linear elasticity on tetrahedra: `P = 2 mu (F - R) +
//! lambda tr(R^T F - I) R`, its energy density, nodal forces, and the force
//! differential for implicit steps with the element stiffness projected to
//! stay positive semi-definite (McAdams et al. 2011: in the frame of the
//! singular value decomposition the differential splits into a 3 x 3 block
//! and three 2 x 2 blocks, whose negative eigenvalues are clamped).

use nalgebra::{Matrix3, Vector3};

/// Lamé parameters from Young's modulus and Poisson's ratio.
pub fn lame(young: f64, poisson: f64) -> (f64, f64) {
    let mu = young / (2.0 * (1.0 + poisson));
    let lambda = young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson));
    (mu, lambda)
}

/// A tetrahedron's rest shape.
#[derive(Clone, Copy, Debug)]
pub struct Rest {
    /// The inverse of the rest edge matrix `[X1 - X0, X2 - X0, X3 - X0]`.
    pub bm: Matrix3<f64>,
    /// Rest volume.
    pub volume: f64,
}

impl Rest {
    /// The rest shape of the tetrahedron at `x` (positively oriented).
    pub fn new(x: [[f64; 3]; 4]) -> Rest {
        let dm = edges(x);
        let volume = dm.determinant() / 6.0;
        Rest {
            bm: dm.try_inverse().unwrap_or_else(Matrix3::zeros),
            volume,
        }
    }

    /// The gradients of the four shape functions (rows of `bm` and minus
    /// their sum).
    pub fn gradients(&self) -> [Vector3<f64>; 4] {
        let g = |i: usize| Vector3::new(self.bm[(i, 0)], self.bm[(i, 1)], self.bm[(i, 2)]);
        let (g1, g2, g3) = (g(0), g(1), g(2));
        [-(g1 + g2 + g3), g1, g2, g3]
    }
}

/// `[x1 - x0, x2 - x0, x3 - x0]` as columns.
pub fn edges(x: [[f64; 3]; 4]) -> Matrix3<f64> {
    let c = |i: usize| Vector3::new(x[i][0] - x[0][0], x[i][1] - x[0][1], x[i][2] - x[0][2]);
    Matrix3::from_columns(&[c(1), c(2), c(3)])
}

/// One tetrahedron's state at the current positions: the rotated frame of
/// its deformation and what its force differential needs.
#[derive(Clone, Copy, Debug)]
pub struct Element {
    /// `F = U diag(sigma) V^T`, `U` and `V` rotations (`sigma[2]` may be
    /// negative for an inverted element).
    pub u: Matrix3<f64>,
    /// See `u`.
    pub v: Matrix3<f64>,
    /// The rest shape's inverse edge matrix times `v` (`B_m V`): the force
    /// differential's two products with it are one each.
    pub bv: Matrix3<f64>,
    /// Singular values.
    pub sigma: [f64; 3],
    /// Clamped eigenvalues of the three 2 x 2 blocks' antisymmetric parts
    /// (pairs 01, 02, 12).
    pub twist: [f64; 3],
    /// Elastic energy density.
    pub psi: f64,
    /// Nodal forces (times the element's weight: rest volume times the
    /// inside fraction).
    pub forces: [Vector3<f64>; 4],
}

/// Material constants.
#[derive(Clone, Copy, Debug)]
pub struct Lame {
    /// Shear modulus.
    pub mu: f64,
    /// First Lamé parameter.
    pub lambda: f64,
}

/// The signed singular value decomposition of `f` (rotations only): `f =
/// U diag(sigma) V^T` with `U`, `V` rotations, `sigma` descending in
/// magnitude and only `sigma[2]` possibly negative (an inverted element).
/// `V` diagonalises `f^T f` by cyclic Jacobi rotations; `U` is the
/// orthonormalised `f V` (as McAdams et al. compute it), completed to a
/// right-handed frame where `f` loses rank.
pub fn svd_rotations(f: &Matrix3<f64>) -> (Matrix3<f64>, [f64; 3], Matrix3<f64>) {
    let mut s = f.transpose() * f;
    let mut v = Matrix3::<f64>::identity();
    let scale = s[(0, 0)] + s[(1, 1)] + s[(2, 2)];
    for _ in 0..JACOBI_SWEEPS {
        let off = s[(0, 1)].powi(2) + s[(0, 2)].powi(2) + s[(1, 2)].powi(2);
        if off <= (1e-17 * scale).powi(2) || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = s[(p, q)];
            if apq == 0.0 {
                continue;
            }
            let theta = (s[(q, q)] - s[(p, p)]) / (2.0 * apq);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let c = 1.0 / (t * t + 1.0).sqrt();
            let sn = t * c;
            // S <- J^T S J, V <- V J with J the rotation in the (p, q) plane.
            for k in 0..3 {
                let (skp, skq) = (s[(k, p)], s[(k, q)]);
                s[(k, p)] = c * skp - sn * skq;
                s[(k, q)] = sn * skp + c * skq;
            }
            for k in 0..3 {
                let (spk, sqk) = (s[(p, k)], s[(q, k)]);
                s[(p, k)] = c * spk - sn * sqk;
                s[(q, k)] = sn * spk + c * sqk;
            }
            for k in 0..3 {
                let (vkp, vkq) = (v[(k, p)], v[(k, q)]);
                v[(k, p)] = c * vkp - sn * vkq;
                v[(k, q)] = sn * vkp + c * vkq;
            }
        }
    }
    // Columns of B = F V in descending length, V's with them.
    let b = f * v;
    let mut idx = [0usize, 1, 2];
    let len2 = [0, 1, 2].map(|i| b.column(i).norm_squared());
    idx.sort_by(|&i, &j| len2[j].total_cmp(&len2[i]));
    let mut v = Matrix3::from_columns(&idx.map(|i| v.column(i).into_owned()));
    if v.determinant() < 0.0 {
        v.set_column(2, &(-v.column(2)));
    }
    let b = f * v;
    // U: Gram-Schmidt on B's first two columns, the third their cross
    // product; the singular values are B's columns along U's.
    let tiny = 1e-30 * scale.max(1e-300);
    let b0 = b.column(0).into_owned();
    let u0 = if b0.norm_squared() > tiny {
        b0.normalize()
    } else {
        Vector3::x()
    };
    let b1 = b.column(1).into_owned();
    let w1 = b1 - u0 * u0.dot(&b1);
    let u1 = if w1.norm_squared() > tiny {
        w1.normalize()
    } else {
        // Rank one or less: any unit vector across u0.
        let a = if u0.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        (a - u0 * u0.dot(&a)).normalize()
    };
    let u2 = u0.cross(&u1);
    let sigma = [u0.dot(&b0), u1.dot(&b1), u2.dot(&b.column(2))];
    (Matrix3::from_columns(&[u0, u1, u2]), sigma, v)
}

/// Most Jacobi sweeps (they converge quadratically: three or four reach
/// rounding).
const JACOBI_SWEEPS: usize = 12;

impl Element {
    /// The element at positions `x` with rest shape `rest`, weighted by
    /// `weight` (its rest volume times the fraction of it inside).
    pub fn at(x: [[f64; 3]; 4], rest: &Rest, weight: f64, m: Lame) -> Element {
        let f = edges(x) * rest.bm;
        let (u, sigma, v) = svd_rotations(&f);
        let t = sigma[0] + sigma[1] + sigma[2] - 3.0;
        let psi = m.mu * sigma.iter().map(|s| (s - 1.0) * (s - 1.0)).sum::<f64>()
            + 0.5 * m.lambda * t * t;
        let p_hat = sigma.map(|s| 2.0 * m.mu * (s - 1.0) + m.lambda * t);
        let p = u * Matrix3::from_diagonal(&Vector3::from(p_hat)) * v.transpose();
        let h = -weight * p * rest.bm.transpose();
        let f1 = h.column(0).into_owned();
        let f2 = h.column(1).into_owned();
        let f3 = h.column(2).into_owned();
        let c = m.lambda * t - 2.0 * m.mu;
        let twist = [(0, 1), (0, 2), (1, 2)].map(|(i, j)| {
            let s = (sigma[i] + sigma[j]).max(1e-6);
            (2.0 * m.mu + 2.0 * c / s).max(0.0)
        });
        Element {
            u,
            v,
            bv: rest.bm * v,
            sigma,
            twist,
            psi,
            forces: [-(f1 + f2 + f3), f1, f2, f3],
        }
    }

    /// An undeformed element of rest shape `rest`: no energy, no force.
    pub fn at_rest(rest: &Rest) -> Element {
        Element {
            u: Matrix3::identity(),
            v: Matrix3::identity(),
            bv: rest.bm,
            sigma: [1.0; 3],
            // At rest `2 mu + 2 (lambda tr - 2 mu) / (s_i + s_j)` is 0.
            twist: [0.0; 3],
            psi: 0.0,
            forces: [Vector3::zeros(); 4],
        }
    }

    /// The projected stress differential in the frame of the
    /// decomposition, for a deformation differential `g` in that frame.
    fn stress_differential(&self, g: &Matrix3<f64>, m: Lame) -> Matrix3<f64> {
        let mut dp = Matrix3::zeros();
        let tr = g[(0, 0)] + g[(1, 1)] + g[(2, 2)];
        for i in 0..3 {
            dp[(i, i)] = 2.0 * m.mu * g[(i, i)] + m.lambda * tr;
        }
        for (k, (i, j)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
            let sym = 0.5 * (g[(i, j)] + g[(j, i)]);
            let anti = 0.5 * (g[(i, j)] - g[(j, i)]);
            dp[(i, j)] = 2.0 * m.mu * sym + self.twist[k] * anti;
            dp[(j, i)] = 2.0 * m.mu * sym - self.twist[k] * anti;
        }
        dp
    }

    /// The projected stiffness `K` (forces `-K dx`): block `[c][d]`, row
    /// major, couples corner `c`'s force to corner `d`'s displacement. The
    /// stress differential's nine columns `T` (one per unit deformation
    /// differential) are contracted with the shape gradients, `K[c][d]_ml =
    /// weight sum_jb g_c[j] T[(m, j), (l, b)] g_d[b]`: the same as the
    /// force differentials of the twelve unit displacements, at about half
    /// their cost.
    pub fn stiffness(&self, rest: &Rest, weight: f64, m: Lame) -> [[[f64; 9]; 4]; 4] {
        // t[l][b] = dP for dF = e_l e_b^T.
        let mut t = [[Matrix3::zeros(); 3]; 3];
        for (l, row) in t.iter_mut().enumerate() {
            for (b, out) in row.iter_mut().enumerate() {
                let g = Matrix3::from_fn(|i, j| self.u[(l, i)] * self.v[(b, j)]);
                *out = self.u * self.stress_differential(&g, m) * self.v.transpose();
            }
        }
        let grads = rest.gradients();
        // w[l][d] = sum_b t[l][b] g_d[b] (a 3 x 3 matrix over (m, j)).
        let w: [[Matrix3<f64>; 4]; 3] = std::array::from_fn(|l| {
            std::array::from_fn(|d| {
                t[l][0] * grads[d][0] + t[l][1] * grads[d][1] + t[l][2] * grads[d][2]
            })
        });
        let mut k = [[[0.0; 9]; 4]; 4];
        for (c, kc) in k.iter_mut().enumerate() {
            for (d, kcd) in kc.iter_mut().enumerate() {
                for l in 0..3 {
                    let col = w[l][d] * grads[c];
                    for mm in 0..3 {
                        kcd[3 * mm + l] = weight * col[mm];
                    }
                }
            }
        }
        k
    }

    /// The force differential for node displacements `dx`: `-K dx` with
    /// the projected (positive semi-definite) stiffness `K`.
    pub fn force_differential(
        &self,
        dx: [Vector3<f64>; 4],
        weight: f64,
        m: Lame,
    ) -> [Vector3<f64>; 4] {
        let d_ds = Matrix3::from_columns(&[dx[1] - dx[0], dx[2] - dx[0], dx[3] - dx[0]]);
        // U^T (dDs B_m) V and (U dP V^T) B_m^T, with B_m V kept.
        let g = self.u.transpose() * d_ds * self.bv;
        let dh = -weight * (self.u * self.stress_differential(&g, m)) * self.bv.transpose();
        let f1 = dh.column(0).into_owned();
        let f2 = dh.column(1).into_owned();
        let f3 = dh.column(2).into_owned();
        [-(f1 + f2 + f3), f1, f2, f3]
    }
}
