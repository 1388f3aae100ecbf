//! Which rows of the film's tangent system an assembly computes again.
//!
//! A row of `I + dt K` is a function of few inputs: its node's fixed flag,
//! tangent basis and interface term, its fan (faces and corners), those
//! faces' elements and their corners' fixed flags and bases, and `dt`.
//! Between two rounds a crack changes them only around itself (0.1-9% of
//! the rows on the teapot's glaze; none in the rounds before the first
//! crack), so each row gets a key hashing those inputs. A row whose key is
//! the last assembly's keeps its entries, moved in place to where the new
//! row lengths put it; only the others are computed. The result is bit for
//! bit the whole assembly's (a row is the same function of the same bits),
//! unless two different inputs give the same 64-bit key.

use crate::sim::implicit::Operator;
use rayon::prelude::*;

/// Fold word `w` into hash `h`: a bijection of `h` for any `w` and of `w`
/// for any `h`, so a key changes whenever one of its words does (and, for
/// several changed words, but for chance: the second product carries a
/// change of any bit of `h ^ w` into the bits above it by way of the
/// state, so no change of one word is undone by a fixed change of the
/// next).
#[inline]
fn mix(h: u64, w: u64) -> u64 {
    let z = (h ^ w).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    (z ^ (z >> 32)).wrapping_mul(0xd6e8_feb8_6659_fd93)
}

/// A key's last step: every bit of it reaches every bit of the result.
#[inline]
fn finish(h: u64) -> u64 {
    let z = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Per node: a key of what its own row and its neighbours' rows read of it
/// (fixed flag, tangent basis, interface term).
pub(super) fn node_keys(op: &Operator, basis: &[[[f64; 3]; 2]], out: &mut Vec<u64>) {
    (0..basis.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|n| {
            let mut h = mix(0x6e6f_6465, u64::from(op.fixed[n]));
            for v in basis[n].iter().flatten() {
                h = mix(h, v.to_bits());
            }
            finish(match op.interface.get(n) {
                Some(k) => mix(mix(h, 1), k.to_bits()),
                None => mix(h, 0),
            })
        })
        .collect_into_vec(out);
}

/// Per face: a key of its corners and of what the rows read of its element
/// (area, normal, gradients; a marker for a face without one).
pub(super) fn face_keys(op: &Operator, out: &mut Vec<u64>) {
    (0..op.fans.n_faces())
        .into_par_iter()
        .with_min_len(1024)
        .map(|f| {
            let mut h = 0x6661_6365;
            for c in op.fans.corners(f) {
                h = mix(h, u64::from(c));
            }
            finish(match op.els.elements.get(f) {
                Some(Some(el)) => {
                    h = mix(h, el.area.to_bits());
                    for v in el.normal.iter().chain(el.grads.iter().flatten()) {
                        h = mix(h, v.to_bits());
                    }
                    h
                }
                Some(None) => mix(h, 1),
                None => mix(h, 2),
            })
        })
        .collect_into_vec(out);
}

/// Per node: the key of its row at step `dt`, from the node and face keys.
pub(super) fn row_keys(op: &Operator, nodes: &[u64], faces: &[u64], dt: f64, out: &mut Vec<u64>) {
    (0..nodes.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|a| {
            let fan = op.fans.fan(a);
            let mut h = mix(mix(dt.to_bits(), nodes[a]), fan.len() as u64);
            for &(f, k) in fan {
                h = mix(h, (u64::from(f) << 8) | u64::from(k));
                h = mix(h, faces[f as usize]);
                for b in op.fans.corners(f as usize) {
                    h = mix(h, nodes[b as usize]);
                }
            }
            finish(h)
        })
        .collect_into_vec(out);
}

/// Move the rows that are kept from their old places (`old` offsets) to
/// their new ones (`new` offsets) in `cols` and `blocks`, in place: `keep`
/// tells the kept rows (all among the old rows). Afterwards both arrays
/// hold `new`'s last offset entries; the rows not kept are left to be
/// written.
///
/// A row moving right never lands on an old row to its right that has not
/// moved yet if those moving right go right to left; those moving left go
/// left to right after them (a row moving left can only land where rows to
/// its left were, never where a row to its right that moves right still
/// is). Runs of kept rows with the same shift move as one block.
pub(super) fn move_kept_rows<A: Copy + Default, B: Copy + Default>(
    old: &[u32],
    new: &[u32],
    keep: &[bool],
    cols: &mut Vec<A>,
    blocks: &mut Vec<B>,
) {
    // (source start, destination start, length) of each run of kept rows
    // with one shift, by the shift's sign.
    let (mut right, mut left) = (Vec::new(), Vec::new());
    let n_old = keep.len().min(old.len().saturating_sub(1));
    let mut a = 0;
    while a < n_old {
        if !keep[a] {
            a += 1;
            continue;
        }
        let shift = i64::from(new[a]) - i64::from(old[a]);
        let start = a;
        while a < n_old && keep[a] && i64::from(new[a]) - i64::from(old[a]) == shift {
            a += 1;
        }
        let (src, len) = (old[start] as usize, (old[a] - old[start]) as usize);
        let dst = new[start] as usize;
        if shift > 0 {
            right.push((src, dst, len));
        } else if shift < 0 {
            left.push((src, dst, len));
        }
    }
    let total = *new.last().unwrap_or(&0) as usize;
    let room = total.max(cols.len());
    cols.resize(room, A::default());
    blocks.resize(room, B::default());
    for &(src, dst, len) in right.iter().rev().chain(left.iter()) {
        cols.copy_within(src..src + len, dst);
        blocks.copy_within(src..src + len, dst);
    }
    cols.truncate(total);
    blocks.truncate(total);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::Lcg;

    /// Rows of random lengths, some kept and others grown, shrunk or new:
    /// every kept row lands where the new offsets say, whole.
    #[test]
    fn kept_rows_land_whole_at_their_new_places() {
        let mut rng = Lcg(3);
        for round in 0..200 {
            let n_old = 1 + (rng.next_f64() * 60.0) as usize;
            let n_new = n_old + (rng.next_f64() * 5.0) as usize;
            let old_len: Vec<u32> = (0..n_old).map(|_| (rng.next_f64() * 6.0) as u32).collect();
            let keep: Vec<bool> = (0..n_old).map(|_| rng.next_f64() < 0.7).collect();
            let new_len: Vec<u32> = (0..n_new)
                .map(|a| match keep.get(a) {
                    Some(true) => old_len[a],
                    _ => (rng.next_f64() * 6.0) as u32,
                })
                .collect();
            let offsets = |lens: &[u32]| {
                std::iter::once(0)
                    .chain(lens.iter().scan(0, |s, &l| {
                        *s += l;
                        Some(*s)
                    }))
                    .collect::<Vec<u32>>()
            };
            let (old, new) = (offsets(&old_len), offsets(&new_len));
            // Each old entry names its row and place in it.
            let mut cols: Vec<(u32, u32)> = (0..n_old as u32)
                .flat_map(|a| (0..old_len[a as usize]).map(move |i| (a, i)))
                .collect();
            let mut blocks: Vec<u64> = cols.iter().map(|&(a, i)| u64::from(a) * 100 + u64::from(i)).collect();
            move_kept_rows(&old, &new, &keep, &mut cols, &mut blocks);
            assert_eq!(cols.len(), *new.last().unwrap() as usize, "round {round}");
            assert_eq!(blocks.len(), cols.len());
            for a in 0..n_old {
                if !keep[a] {
                    continue;
                }
                for i in 0..old_len[a] {
                    let at = (new[a] + i) as usize;
                    assert_eq!(cols[at], (a as u32, i), "round {round}, row {a}");
                    assert_eq!(blocks[at], a as u64 * 100 + u64::from(i));
                }
            }
        }
    }
}
