//! Per-triangle quantities of the simulation: area, unit normal, tangent
//! frame and barycentric gradients, with the paper's conditioning cap.
//!
//! The gradients `g_i = grad(lambda_i)` are stored as world-space vectors in
//! the triangle's plane (`E_e` times the 2D rows of the paper's `beta`). Large
//! singular values of `beta` (sliver triangles) are clamped to a threshold so
//! that forces and stiffness stay bounded (Iben & O'Brien 2009, sec. 4.3).

use crate::math::v3;

/// Geometry of one triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Element {
    /// Area (of the real triangle, not of the clamped basis).
    pub area: f64,
    /// Unit normal (counter-clockwise winding).
    pub normal: [f64; 3],
    /// First tangent axis (along the edge from corner 0 to corner 1).
    pub e1: [f64; 3],
    /// Second tangent axis, `normal x e1`.
    pub e2: [f64; 3],
    /// Barycentric gradients of the three corners (they sum to zero).
    pub grads: [[f64; 3]; 3],
    /// Whether the basis was clamped.
    pub clamped: bool,
}

/// The largest singular value of the barycentric basis of a triangle (about
/// `1 / smallest height`), or `None` for a degenerate triangle.
pub fn basis_norm(p: [[f64; 3]; 3]) -> Option<f64> {
    let (beta, _, _, _) = basis(p)?;
    Some(singular_values(beta).0)
}

/// Frame and the 2x2 `beta = D^{-1}` (rows: gradients of lambda_1, lambda_2).
#[allow(clippy::type_complexity)]
fn basis(p: [[f64; 3]; 3]) -> Option<([[f64; 2]; 2], [f64; 3], [f64; 3], [f64; 3])> {
    let a = v3::sub(p[1], p[0]);
    let b = v3::sub(p[2], p[0]);
    let n = v3::cross(a, b);
    let nn = v3::norm(n);
    let la = v3::norm(a);
    if !(nn > 0.0 && la > 0.0 && nn.is_finite()) {
        return None;
    }
    let normal = v3::scale(n, 1.0 / nn);
    let e1 = v3::scale(a, 1.0 / la);
    let e2 = v3::cross(normal, e1);
    // D = [a b] in the frame: columns (la, 0) and (b.e1, b.e2).
    let (bx, by) = (v3::dot(b, e1), v3::dot(b, e2));
    // D = [[la, bx], [0, by]]; D^{-1} = [[1/la, -bx/(la by)], [0, 1/by]]
    let det = la * by;
    if det.abs() < f64::MIN_POSITIVE || !det.is_finite() {
        return None;
    }
    let beta = [[1.0 / la, -bx / det], [0.0, 1.0 / by]];
    Some((beta, normal, e1, e2))
}

/// Singular values (largest first) and the SVD `beta = U diag(s) V^T` of a 2x2 matrix.
#[allow(clippy::type_complexity)]
fn svd2(m: [[f64; 2]; 2]) -> ([f64; 2], [[f64; 2]; 2], [[f64; 2]; 2]) {
    let [[a, b], [c, d]] = m;
    // Standard closed form via the polar angles.
    let e = 0.5 * (a + d);
    let f = 0.5 * (a - d);
    let g = 0.5 * (c + b);
    let h = 0.5 * (c - b);
    let q = e.hypot(h);
    let r = f.hypot(g);
    let s1 = q + r;
    let s2 = q - r; // may be negative: sign folded into V
    let a1 = g.atan2(f);
    let a2 = h.atan2(e);
    let theta = 0.5 * (a2 - a1);
    let phi = 0.5 * (a2 + a1);
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    let u = [[cp, -sp], [sp, cp]];
    let (s2a, sign) = if s2 < 0.0 { (-s2, -1.0) } else { (s2, 1.0) };
    // V^T = diag(1, sign) * [[ct, -st], [st, ct]]
    let vt = [[ct, -st], [sign * st, sign * ct]];
    ([s1, s2a], u, vt)
}

fn singular_values(m: [[f64; 2]; 2]) -> (f64, f64) {
    let (s, _, _) = svd2(m);
    (s[0].max(s[1]), s[0].min(s[1]))
}

impl Element {
    /// Compute the element for corner positions `p`. Singular values of the
    /// barycentric basis above `clamp` are clamped to it (`f64::INFINITY`: no
    /// clamping). `None` for a degenerate triangle.
    pub fn new(p: [[f64; 3]; 3], clamp: f64) -> Option<Element> {
        let (mut beta, normal, e1, e2) = basis(p)?;
        let mut clamped = false;
        let (s, u, vt) = svd2(beta);
        if s[0] > clamp || s[1] > clamp {
            let c = [s[0].min(clamp), s[1].min(clamp)];
            for (i, row) in beta.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = u[i][0] * c[0] * vt[0][j] + u[i][1] * c[1] * vt[1][j];
                }
            }
            clamped = true;
        }
        let to_world = |r: [f64; 2]| v3::add(v3::scale(e1, r[0]), v3::scale(e2, r[1]));
        // beta rows are grad(lambda_1), grad(lambda_2) as row vectors in the frame:
        // grad lambda_k = (beta[k-1][0], beta[k-1][1]).
        let g1 = to_world(beta[0]);
        let g2 = to_world(beta[1]);
        let g0 = v3::scale(v3::add(g1, g2), -1.0);
        let area = 0.5 * v3::norm(v3::cross(v3::sub(p[1], p[0]), v3::sub(p[2], p[0])));
        Some(Element {
            area,
            normal,
            e1,
            e2,
            grads: [g0, g1, g2],
            clamped,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradients_are_barycentric() {
        let p = [[0.1, 0.2, 0.3], [1.3, 0.1, 0.5], [0.4, 1.1, -0.2]];
        let e = Element::new(p, f64::INFINITY).unwrap();
        // grad(lambda_i) . (p_j - p_k) = delta_ij - delta_ik
        for i in 0..3 {
            for j in 0..3 {
                let d = v3::dot(e.grads[i], v3::sub(p[j], p[0]));
                let want = if i == j { 1.0 } else { 0.0 } - if i == 0 { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-12, "i {i} j {j}: {d} vs {want}");
            }
            assert!(v3::dot(e.grads[i], e.normal).abs() < 1e-12);
        }
        assert!(!e.clamped);
    }

    #[test]
    fn svd_reconstructs() {
        for m in [
            [[1.0, 2.0], [0.0, 3.0]],
            [[0.5, -1.5], [0.0, 0.2]],
            [[2.0, 0.0], [0.0, -1.0]],
        ] {
            let (s, u, vt) = svd2(m);
            for i in 0..2 {
                for j in 0..2 {
                    let r = u[i][0] * s[0] * vt[0][j] + u[i][1] * s[1] * vt[1][j];
                    assert!((r - m[i][j]).abs() < 1e-12, "{m:?}");
                }
            }
        }
    }

    #[test]
    fn sliver_is_clamped_and_gradients_still_sum_to_zero() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 1e-6, 0.0]];
        let free = Element::new(p, f64::INFINITY).unwrap();
        let norm = |e: &Element| e.grads.iter().map(|g| v3::norm(*g)).fold(0.0, f64::max);
        assert!(norm(&free) > 1e5);
        let c = Element::new(p, 10.0).unwrap();
        assert!(c.clamped);
        assert!(norm(&c) <= 10.0 * 2.0 + 1e-9);
        let s = v3::add(v3::add(c.grads[0], c.grads[1]), c.grads[2]);
        assert!(v3::norm(s) < 1e-12);
        assert!(Element::new([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], 1.0).is_none());
    }
}
