//! The load of a round: shrinkage times each face's scale plus the stress
//! field's evolution, added to the element stress over a load step.

use crate::geometry::element::Element;
use crate::math::Sym3;
use crate::sim::forces::Elements;
use rayon::prelude::*;

/// Add the stress `load` adds in its step to every face (nothing when the
/// load does not act).
pub(in crate::sim) fn add_load(
    stress: &mut [Sym3],
    els: &Elements,
    scale: &[f64],
    evolve: &[Sym3],
    load: Load,
) {
    if load.dt <= 0.0 {
        return;
    }
    stress
        .par_iter_mut()
        .zip(els.elements.par_iter())
        .enumerate()
        .for_each(|(f, (s, el))| {
            if let Some(el) = el {
                *s += load_increment(scale, evolve, f, el, load);
            }
        });
}

/// The stress the load adds to face `f` during one step.
#[inline]
pub(in crate::sim) fn load_increment(
    scale: &[f64],
    evolve: &[Sym3],
    f: usize,
    el: &Element,
    load: Load,
) -> Sym3 {
    if load.dt <= 0.0 {
        return Sym3::ZERO;
    }
    let k = load.dt * scale[f];
    let mut ds = Sym3::tangent_identity(el.normal, k * load.shrink_rate);
    if let Some(e) = evolve.get(f) {
        ds += *e * k;
    }
    ds
}

/// The load acting during one step.
#[derive(Clone, Copy)]
pub(in crate::sim) struct Load {
    /// Time the load acts in this step (0 when held or complete).
    pub(in crate::sim) dt: f64,
    /// Uniform shrinkage per unit time.
    pub(in crate::sim) shrink_rate: f64,
}
