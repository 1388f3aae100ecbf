//! OBJ text of meshes as a DCC tool makes them: regular and jittered plates, a
//! latitude-longitude sphere and an icosphere. Include with
//! `#[path = "common/shapes.rs"] mod shapes;`. Positions carry 17 significant digits.
#![allow(dead_code)]

use std::fmt::Write as _;
use std::path::Path;

type P3 = [f64; 3];

fn obj_text(header: &str, verts: &[P3], faces: &[Vec<usize>]) -> String {
    let mut s = String::with_capacity(60 * verts.len() + 24 * faces.len());
    let _ = writeln!(
        s,
        "# {header}\n# {} vertices, {} faces",
        verts.len(),
        faces.len()
    );
    for v in verts {
        let _ = writeln!(s, "v {:.16e} {:.16e} {:.16e}", v[0], v[1], v[2]);
    }
    for f in faces {
        s.push('f');
        for i in f {
            let _ = write!(s, " {}", i + 1);
        }
        s.push('\n');
    }
    s
}

/// Plate grid positions: (n+1)^2 vertices in the xz-plane, centred, y = 0, `size` wide.
fn plate_vertices(n: usize, size: f64) -> Vec<P3> {
    let at = |k: usize| -0.5 * size + size * k as f64 / n as f64;
    let mut v = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            v.push([at(i), 0.0, at(j)]);
        }
    }
    v
}

/// Two triangles a quad, all split along the diagonal (i, j)-(i+1, j+1), facing +y.
fn plate_faces(n: usize) -> Vec<Vec<usize>> {
    let id = |i: usize, j: usize| j * (n + 1) + i;
    let mut f = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
            f.push(vec![id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            f.push(vec![id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    f
}

/// OBJ of an n x n quad plate `size` wide in the xz-plane (y up), every quad split along the same diagonal.
pub fn regular_plate(n: usize, size: f64) -> String {
    let header = format!("regular plate {n}x{n}, size {size}, xz-plane, one diagonal");
    obj_text(&header, &plate_vertices(n, size), &plate_faces(n))
}

/// OBJ of `regular_plate(n, size)` with each vertex lifted to `height(x, z)`
/// (called in vertex order, rows of x for increasing z): a ground patch.
pub fn height_plate(n: usize, size: f64, mut height: impl FnMut(f64, f64) -> f64) -> String {
    let mut v = plate_vertices(n, size);
    for p in &mut v {
        p[1] = height(p[0], p[2]);
    }
    let header = format!("regular plate {n}x{n}, size {size}, xz-plane, heights");
    obj_text(&header, &v, &plate_faces(n))
}

/// OBJ of the triangles of `regular_plate(n, size)` whose centroids lie in the
/// plate's inscribed disc: the grid's rows inside a border that has no direction.
pub fn regular_disc(n: usize, size: f64) -> String {
    let v = plate_vertices(n, size);
    let r2 = 0.25 * size * size;
    let faces: Vec<Vec<usize>> = plate_faces(n)
        .into_iter()
        .filter(|f| {
            let c = |k: usize| f.iter().map(|&i| v[i][k]).sum::<f64>() / 3.0;
            c(0) * c(0) + c(2) * c(2) < r2
        })
        .collect();
    let mut used: Vec<usize> = faces.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let mut at = vec![usize::MAX; v.len()];
    for (k, &i) in used.iter().enumerate() {
        at[i] = k;
    }
    let verts: Vec<P3> = used.iter().map(|&i| v[i]).collect();
    let faces: Vec<Vec<usize>> = faces
        .into_iter()
        .map(|f| f.into_iter().map(|i| at[i]).collect())
        .collect();
    let header = format!("regular grid {n}x{n} clipped to its inscribed disc, size {size}");
    obj_text(&header, &verts, &faces)
}

/// OBJ of `regular_plate` with interior vertices moved in x and z by up to `jitter` cells (LCG from `seed`).
pub fn jittered_plate(n: usize, size: f64, jitter: f64, seed: u64) -> String {
    let mut state = seed;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut v = plate_vertices(n, size);
    let cell = size / n as f64;
    for j in 1..n {
        for i in 1..n {
            let p = &mut v[j * (n + 1) + i];
            p[0] += jitter * cell * next();
            p[2] += jitter * cell * next();
        }
    }
    let header = format!("jittered plate {n}x{n}, size {size}, jitter {jitter}, seed {seed}");
    obj_text(&header, &v, &plate_faces(n))
}

/// OBJ of a unit UV sphere, poles on z: `nu` segments around, `nv` rings, quads and pole fans.
pub fn latlong_sphere(nu: usize, nv: usize) -> String {
    let mut v: Vec<P3> = vec![[0.0, 0.0, 1.0]];
    for k in 1..nv {
        let theta = std::f64::consts::PI * k as f64 / nv as f64;
        for i in 0..nu {
            let phi = std::f64::consts::TAU * i as f64 / nu as f64;
            v.push([
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    v.push([0.0, 0.0, -1.0]);
    let bottom = v.len() - 1;
    let ring = |k: usize, i: usize| 1 + (k - 1) * nu + i % nu;
    let mut f = Vec::new();
    for i in 0..nu {
        f.push(vec![0, ring(1, i), ring(1, i + 1)]);
    }
    for k in 1..nv - 1 {
        for i in 0..nu {
            f.push(vec![
                ring(k, i),
                ring(k + 1, i),
                ring(k + 1, i + 1),
                ring(k, i + 1),
            ]);
        }
    }
    for i in 0..nu {
        f.push(vec![bottom, ring(nv - 1, i + 1), ring(nv - 1, i)]);
    }
    obj_text(&format!("UV sphere {nu}x{nv}, poles on z"), &v, &f)
}

/// OBJ of a unit icosphere: an icosahedron with each triangle split into 4,
/// `subdivisions` times (the crate's own test shape, written as a file).
pub fn icosphere(subdivisions: u32) -> String {
    let m = crackle::mesh::shapes::icosphere_input(subdivisions as usize);
    let faces: Vec<Vec<usize>> = m
        .triangles
        .iter()
        .map(|t| t.iter().map(|&i| i as usize).collect())
        .collect();
    obj_text(
        &format!("icosphere, {subdivisions} subdivisions"),
        &m.positions,
        &faces,
    )
}

/// OBJ text with every vertex line's position moved by `f`, the other
/// lines as they are.
pub fn map_vertices(text: &str, f: impl Fn([f64; 3]) -> [f64; 3]) -> String {
    text.lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let p: Vec<f64> = rest
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                let q = f([p[0], p[1], p[2]]);
                format!("v {:e} {:e} {:e}\n", q[0], q[1], q[2])
            }
            None => format!("{l}\n"),
        })
        .collect()
}

/// Writes OBJ text to `path`, creating its folder.
pub fn write_obj(path: &Path, text: &str) {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    }
    std::fs::write(path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}
