//! Test shapes shared by unit tests, integration tests and benches: grids,
//! jittered plates, icospheres and a cube, from a seeded generator (the same
//! shape on every platform).

use super::{Channel, ChannelKind, MeshInput, SimMesh, WeldOptions};

/// A deterministic linear congruential generator.
pub struct Lcg(pub u64);

impl Lcg {
    /// Next value in `[0, 1)`.
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Next value in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_f64() * n as f64) as usize).min(n - 1)
    }
}

/// An `nx` x `ny` grid of unit quads in the z = 0 plane, each split along
/// its diagonal, with a `uv` channel equal to (x, y).
pub fn grid_input(nx: usize, ny: usize) -> MeshInput {
    let mut positions = Vec::new();
    let mut uv = Vec::new();
    for j in 0..=ny {
        for i in 0..=nx {
            positions.push([i as f64, j as f64, 0.0]);
            uv.extend_from_slice(&[i as f64, j as f64]);
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut triangles = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    MeshInput {
        positions,
        triangles,
        face_groups: vec![],
        wedge_channels: vec![Channel::new("uv", 2, ChannelKind::Linear, uv)],
    }
}

/// Builds `input` with default options and validates it.
pub fn build(input: &MeshInput) -> (SimMesh, super::DefectReport) {
    let (m, r) = SimMesh::build(input, &WeldOptions::default()).expect("build");
    m.validate().expect("valid after build");
    (m, r)
}

/// A unit icosphere subdivided `level` times, as an indexed mesh (shared
/// vertices) with a unit-normal channel.
pub fn icosphere_input(level: usize) -> MeshInput {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut p: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let normalize = |a: [f64; 3]| {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        [a[0] / l, a[1] / l, a[2] / l]
    };
    for x in &mut p {
        *x = normalize(*x);
    }
    for _ in 0..level {
        let mut mid = std::collections::BTreeMap::new();
        let mut next = Vec::new();
        for tri in &tris {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[k] = *mid.entry(key).or_insert_with(|| {
                    let (pa, pb) = (p[a as usize], p[b as usize]);
                    p.push(normalize([pa[0] + pb[0], pa[1] + pb[1], pa[2] + pb[2]]));
                    (p.len() - 1) as u32
                });
            }
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push([m[0], m[1], m[2]]);
        }
        tris = next;
    }
    let normals = p.iter().flatten().copied().collect();
    MeshInput {
        positions: p,
        triangles: tris,
        face_groups: vec![],
        wedge_channels: vec![Channel::new("n", 3, ChannelKind::UnitVector, normals)],
    }
}

/// A unit cube as 24 vertices (4 per face, per-face normals), 12 triangles.
pub fn cube24_input() -> MeshInput {
    // (normal, u axis, v axis) per face; corners c + (+-u +-v) / 2.
    let faces: [([f64; 3], [f64; 3], [f64; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
    ];
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    for (n, u, v) in faces {
        let base = positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            positions.push(std::array::from_fn(|k| {
                0.5 * n[k] + 0.5 * su * u[k] + 0.5 * sv * v[k]
            }));
            normals.extend_from_slice(&n);
        }
        triangles.push([base, base + 1, base + 2]);
        triangles.push([base, base + 2, base + 3]);
    }
    MeshInput {
        positions,
        triangles,
        face_groups: (0..12).map(|t| t / 2).collect(),
        wedge_channels: vec![Channel::new("NORMAL", 3, ChannelKind::UnitVector, normals)],
    }
}

/// An `n` x `n` grid of unit quads over `[0, n]^2` at z = 0 ([`grid_input`],
/// with its `uv`), interior vertices jittered in x and y by up to `jitter`
/// cells from generator seed `seed`.
pub fn jittered_plate_input(n: usize, jitter: f64, seed: u64) -> MeshInput {
    let mut input = grid_input(n, n);
    let mut rng = Lcg(seed);
    for p in input.positions.iter_mut() {
        let interior = p[0] > 0.0 && p[0] < n as f64 && p[1] > 0.0 && p[1] < n as f64;
        if interior {
            p[0] += jitter * (2.0 * rng.next_f64() - 1.0);
            p[1] += jitter * (2.0 * rng.next_f64() - 1.0);
        }
    }
    input
}

/// [`jittered_plate_input`] welded into a simulation mesh.
///
/// # Panics
/// Never for `n >= 1` and `jitter < 0.5` (the plate is a valid mesh).
pub fn jittered_plate(n: usize, jitter: f64, seed: u64) -> SimMesh {
    let (m, _) = SimMesh::build(
        &jittered_plate_input(n, jitter, seed),
        &WeldOptions::default(),
    )
    .expect("a jittered plate is a valid mesh");
    m
}
