//! Triangles' neighbours by position: vertex ids that equal positions
//! share (UV and normal seams are not borders) and the triangles across
//! each edge.

/// A vertex id per position: equal positions get the same id.
pub fn weld(positions: &[[f64; 3]]) -> Vec<u32> {
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    let key = |i: u32| positions[i as usize].map(|x| (x + 0.0).to_bits());
    order.sort_by_key(|&i| (key(i), i));
    let mut id = vec![0u32; positions.len()];
    let mut current = 0u32;
    for (k, &i) in order.iter().enumerate() {
        if k > 0 && key(order[k - 1]) == key(i) {
            id[i as usize] = id[order[k - 1] as usize];
        } else {
            id[i as usize] = current;
            current += 1;
        }
    }
    id
}

/// Per triangle, its neighbours across edges two triangles share (welded):
/// entry `k` is the triangle across the edge from corner `k` to corner
/// `k + 1`, `u32::MAX` at a border or an edge of more than two triangles.
pub fn neighbours(welded: &[u32], triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut edges: Vec<((u32, u32), u32, u8)> = Vec::with_capacity(triangles.len() * 3);
    for (f, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let a = welded[t[k] as usize];
            let b = welded[t[(k + 1) % 3] as usize];
            if a != b {
                edges.push(((a.min(b), a.max(b)), f as u32, k as u8));
            }
        }
    }
    edges.sort_unstable();
    let mut out = vec![[u32::MAX; 3]; triangles.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i == 2 {
            let (_, f, k) = edges[i];
            let (_, g, l) = edges[i + 1];
            out[f as usize][k as usize] = g;
            out[g as usize][l as usize] = f;
        }
        i = j;
    }
    out
}
