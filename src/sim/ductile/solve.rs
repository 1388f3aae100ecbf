//! The elastic step: backward Euler, linearised once about the current
//! positions (Baraff & Witkin), solved matrix-free by preconditioned CG on
//! `((1 + dt a) M + (dt b + dt^2) K) dv = dt (f + f_ext - a M v) -
//! dt (b + dt) K v`, with Rayleigh damping `a M + b K` and the projected
//! stiffness `K` of [`super::fem`]; pulled nodes get their velocity.
//! Every sum over a node's tetrahedra runs in a fixed order.

use super::fem::Element;
use super::multigrid::{Multigrid, Operator};
use super::params::PullMode;
use super::{Ductile, KeptCycle, StepReport};
use crate::sim::cg::{self, CgReport, Vectors};
use nalgebra::Vector3;
use rayon::prelude::*;

impl Ductile {
    /// `K p` at every node (zero where `p` is zero on all its tetrahedra).
    fn stiffness_product(
        &self,
        elements: &[Element],
        weights: &[f64],
        p: &[[f64; 3]],
    ) -> Vec<[f64; 3]> {
        let per_tet: Vec<[Vector3<f64>; 4]> = (0..self.tets.len())
            .into_par_iter()
            .map(|e| {
                if weights[e] <= 0.0 {
                    return [Vector3::zeros(); 4];
                }
                let dx = self.tets[e].map(|n| Vector3::from(p[n as usize]));
                elements[e].force_differential(dx, weights[e], self.lame)
            })
            .collect();
        self.node_tets
            .par_iter()
            .map(|ts| {
                let mut acc = Vector3::zeros();
                for &(e, c) in ts {
                    acc -= per_tet[e as usize][c as usize];
                }
                [acc[0], acc[1], acc[2]]
            })
            .collect()
    }

    /// Build the multigrid cycle for this step's operator `cm M + ck K`,
    /// unless the one kept from an earlier step still works: the operator
    /// changes little from one quasistatic step to the next, so a cycle is
    /// kept until the material tears (which changes the operator where it
    /// matters most) or a solve takes a quarter more iterations than the
    /// first solve with it (any SPD cycle is a valid preconditioner; only the
    /// count of iterations depends on its age). A tear that splits the
    /// material (or sheds a piece) builds it anew: each piece gets its own
    /// coarse levels. Returns whether it built one: its finest level is
    /// then this step's operator.
    fn refresh_multigrid(
        &mut self,
        elements: &[Element],
        weights: &[f64],
        mass: &[f64],
        fixed: &[[bool; 3]],
        (cm, ck): (f64, f64),
    ) -> bool {
        let kept = self.mg.take();
        let working = kept
            .as_ref()
            .is_some_and(|mg| mg.last <= mg.iterations + mg.iterations / 4 + 2);
        // Virtual nodes made since (a tear) change the unknowns.
        let same = kept
            .as_ref()
            .is_some_and(|mg| mg.multigrid.unknowns() == self.x.len());
        if working && same && !kept.as_ref().is_some_and(|mg| mg.torn) {
            self.mg = kept;
            return false;
        }
        let pieces = self.piece_nodes();
        let split = kept
            .as_ref()
            .is_some_and(|mg| mg.multigrid.pieces != pieces.len().max(1));
        let cm_mass: Vec<f64> = mass.iter().map(|m| cm * m).collect();
        let stiffness = |e: usize| self.element_stiffness(elements, weights, e, ck);
        let op = Operator {
            dims: self.grid.nodes_per_axis(),
            tets: &self.tets,
            home: &self.home,
            stiffness: &stiffness,
            mass: &cm_mass,
            fixed,
            pieces: &pieces,
        };
        let cycle = match kept {
            // Torn since built, but solving as fast as when built and in
            // as many pieces: this step's operator on the finest level, the
            // coarser ones kept.
            Some(mut mg) if working && !split => {
                mg.multigrid.refine(&op);
                mg.torn = false;
                mg
            }
            _ => KeptCycle {
                multigrid: Multigrid::new(&op),
                iterations: usize::MAX,
                last: 0,
                torn: false,
            },
        };
        if !working || split {
            self.mg_builds += 1;
        }
        self.mg = Some(cycle);
        true
    }

    /// Tetrahedron `e`'s stiffness times `ck`, block `[c][d]` coupling
    /// corner `c`'s force to corner `d`'s displacement.
    fn element_stiffness(
        &self,
        elements: &[Element],
        weights: &[f64],
        e: usize,
        ck: f64,
    ) -> [[[f64; 9]; 4]; 4] {
        if weights[e] <= 0.0 {
            return [[[0.0; 9]; 4]; 4];
        }
        elements[e].stiffness(&self.rest[e], ck * weights[e], self.lame)
    }

    /// Elastic forces at every node.
    fn elastic_forces(&self, elements: &[Element]) -> Vec<[f64; 3]> {
        self.node_tets
            .par_iter()
            .map(|ts| {
                let mut acc = Vector3::zeros();
                for &(e, c) in ts {
                    acc += elements[e as usize].forces[c as usize];
                }
                [acc[0], acc[1], acc[2]]
            })
            .collect()
    }

    /// A diagonal estimate of `K` per node (scalar): the tetrahedra's
    /// `(2 mu + lambda) |grad N|^2` times their weight.
    fn stiffness_diagonal(&self, weights: &[f64]) -> Vec<f64> {
        let k = 2.0 * self.lame.mu + self.lame.lambda;
        self.node_tets
            .par_iter()
            .map(|ts| {
                ts.iter()
                    .map(|&(e, c)| {
                        weights[e as usize]
                            * k
                            * self.rest[e as usize].gradients()[c as usize].norm_squared()
                    })
                    .sum()
            })
            .collect()
    }

    /// External forces: the pull's traction in force mode, spread over each
    /// slab by mass.
    fn external_forces(&self, mass: &[f64]) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; self.x.len()];
        let p = &self.params.pull;
        if p.mode != PullMode::Force {
            return f;
        }
        let ramp = if p.ramp > 0.0 {
            (self.time / p.ramp).min(1.0)
        } else {
            1.0
        };
        for side in [-1i8, 1] {
            let slab_mass: f64 = (0..self.x.len())
                .filter(|&n| self.pulled[n] == side)
                .map(|n| mass[n])
                .sum();
            if slab_mass <= 0.0 {
                continue;
            }
            // The slab's cross-section: its volume over its thickness.
            let area = slab_mass / self.params.density / self.slab_thickness;
            let total = ramp * p.force * area;
            for n in (0..self.x.len()).filter(|&n| self.pulled[n] == side) {
                f[n][self.axis] = f64::from(side) * total * mass[n] / slab_mass;
            }
        }
        f
    }

    /// The implicit step of length `dt`; updates `v` and `x`.
    pub(super) fn implicit_step(
        &mut self,
        dt: f64,
        weights: &[f64],
        elements: &[Element],
        mass: &[f64],
    ) -> StepReport {
        let n = self.x.len();
        let (a, b) = (self.params.damping, self.params.stiffness_damping);
        let (cm, ck) = (1.0 + dt * a, dt * b + dt * dt);
        let fe = self.elastic_forces(elements);
        let fx = self.external_forces(mass);
        let kv = self.stiffness_product(elements, weights, &self.v);
        let speed = self.pull_speed_now();
        let velocity_pull = self.params.pull.mode == PullMode::Velocity;
        // Fixed unknowns: nodes without material, and the pull's component
        // of pulled nodes (while the object is whole they slide freely
        // across it, as in a grip that lets the material narrow); once it
        // has come apart, every component of them (see `grips_hold`).
        let fixed: Vec<[bool; 3]> = (0..n)
            .map(|i| {
                if mass[i] <= 0.0 {
                    [true; 3]
                } else if velocity_pull && self.pulled[i] != 0 {
                    std::array::from_fn(|k| self.grip_holds(k))
                } else {
                    [false; 3]
                }
            })
            .collect();
        let rhs: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                std::array::from_fn(|k| {
                    dt * (fe[i][k] + fx[i][k] - a * mass[i] * self.v[i][k])
                        - dt * (b + dt) * kv[i][k]
                })
            })
            .collect();
        // Free unknowns start from the last step's change (quasistatic
        // pulls change little from step to step).
        let mut x: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                std::array::from_fn(|k| {
                    if mass[i] <= 0.0 {
                        0.0
                    } else if fixed[i][k] {
                        self.grip_velocity(i, k, speed) - self.v[i][k]
                    } else {
                        self.last_dv.get(i).map_or(0.0, |d| d[k])
                    }
                })
            })
            .collect();
        let apply = |p: &[[f64; 3]], kp: &[[f64; 3]], i: usize| -> [f64; 3] {
            std::array::from_fn(|k| cm * mass[i] * p[i][k] + ck * kp[i][k])
        };
        // A cycle built for this step holds its operator, assembled: the
        // CG's products read it (a kept cycle's is an earlier step's).
        let assembled = self.params.multigrid
            && self.refresh_multigrid(elements, weights, mass, &fixed, (cm, ck));
        // r = b - A x on the free unknowns.
        let kx = self.stiffness_product(elements, weights, &x);
        let mut r: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let ax = apply(&x, &kx, i);
                std::array::from_fn(|k| if fixed[i][k] { 0.0 } else { rhs[i][k] - ax[k] })
            })
            .collect();
        let norm_b = cg::dot(&r, &r).sqrt().max(1e-300);
        let mut report = CgReport::default();
        if cg::dot(&r, &r).sqrt() > 0.0 {
            let (mut z, mut p, mut ap) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
            let product = |p: &[[f64; 3]], ap: &mut [[f64; 3]]| -> f64 {
                if assembled {
                    let mg = &self.mg.as_ref().expect("a cycle built").multigrid;
                    mg.product(p, ap);
                    return cg::dot(p, ap);
                }
                let kp = self.stiffness_product(elements, weights, p);
                ap.par_iter_mut().enumerate().for_each(|(i, out)| {
                    let full = apply(p, &kp, i);
                    *out = std::array::from_fn(|k| if fixed[i][k] { 0.0 } else { full[k] });
                });
                cg::dot(p, ap)
            };
            let vectors = Vectors {
                x: &mut x,
                r: &mut r,
                z: &mut z,
                p: &mut p,
                ap: &mut ap,
            };
            // Without a multigrid cycle: the diagonal of the operator.
            let diag: Vec<f64> = if self.mg.is_some() {
                Vec::new()
            } else {
                let kdiag = self.stiffness_diagonal(weights);
                (0..n)
                    .map(|i| (cm * mass[i] + ck * kdiag[i]).max(1e-300))
                    .collect()
            };
            let precondition = |r: &[[f64; 3]], z: &mut [[f64; 3]]| {
                match &self.mg {
                    Some(mg) => mg.multigrid.apply(r, z),
                    None => z.par_iter_mut().zip(r).enumerate().for_each(|(i, (z, r))| {
                        *z = std::array::from_fn(|k| r[k] / diag[i]);
                    }),
                }
                // Fixed unknowns stay put (a kept cycle may predate some).
                z.par_iter_mut().zip(&fixed).for_each(|(z, f)| {
                    for k in 0..3 {
                        if f[k] {
                            z[k] = 0.0;
                        }
                    }
                });
            };
            let (tol, max) = (self.params.tolerance, self.params.max_cg);
            cg::iterate_with(
                product,
                precondition,
                vectors,
                norm_b,
                tol,
                max,
                &mut report,
            );
        } else {
            report.converged = true;
        }
        if let Some(mg) = &mut self.mg {
            if mg.iterations == usize::MAX {
                mg.iterations = report.iterations;
            }
            mg.last = report.iterations;
        }
        self.last_dv.clone_from(&x);
        for (((v, p), dv), m) in self.v.iter_mut().zip(self.x.iter_mut()).zip(&x).zip(mass) {
            if *m <= 0.0 {
                // No material left: nothing moves it (and no stale speed
                // bounds the next step).
                *v = [0.0; 3];
                continue;
            }
            for k in 0..3 {
                v[k] += dv[k];
                p[k] += dt * v[k];
            }
        }
        StepReport {
            cg_iterations: report.iterations,
            cg_residual: report.relative_residual,
            converged: report.converged,
            ..Default::default()
        }
    }

    /// One explicit (symplectic Euler) step of length `dt` with mass
    /// damping only, for comparison with the implicit step at small `dt`.
    pub fn explicit_step(&mut self, dt: f64) {
        let weights = self.weights();
        let elements = self.elements(&weights);
        let mass = self.masses(&weights);
        let fe = self.elastic_forces(&elements);
        let fx = self.external_forces(&mass);
        let speed = self.pull_speed_now();
        let a = self.params.damping;
        for i in 0..self.x.len() {
            if mass[i] <= 0.0 {
                continue;
            }
            for k in 0..3 {
                self.v[i][k] += dt * ((fe[i][k] + fx[i][k]) / mass[i] - a * self.v[i][k]);
            }
            if self.params.pull.mode == PullMode::Velocity && self.pulled[i] != 0 {
                for k in 0..3 {
                    if self.grip_holds(k) {
                        self.v[i][k] = self.grip_velocity(i, k, speed);
                    }
                }
            }
            for k in 0..3 {
                self.x[i][k] += dt * self.v[i][k];
            }
        }
        self.time += dt;
        self.update_pulled_by();
    }
}
