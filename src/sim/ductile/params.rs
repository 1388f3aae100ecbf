//! Parameters of `model = "ductile"` (`[simulation.ductile]`).

use crate::sim::ParamError;

/// Why the fixed groups cannot be the pull's grips.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GripError {
    /// The fixed groups select no face.
    #[error("the fixed groups have no faces to pull by")]
    NoFaces,
    /// Every grip face lies on one side of the object's centre.
    #[error("the fixed groups all lie on one side of the object along {axis} (the pull moves the grips below its centre one way and those above the other): name groups on both ends")]
    OneSide {
        /// The pull's axis (`x`, `y` or `z`).
        axis: &'static str,
    },
}

/// How the pull moves its slabs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PullMode {
    /// The slabs move at `speed`, ramped up over `ramp` seconds.
    #[default]
    Velocity,
    /// A traction `force` (Pa) pulls each slab outward, ramped up over
    /// `ramp` seconds; the slabs move as the material lets them.
    Force,
}

/// What is pulled: the nodes within `slab` of each end of the object along
/// `axis`, moved apart.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Pull {
    /// `"x"`, `"y"`, `"z"` or `"long"` (the object's longest side).
    /// Default `"long"`.
    pub axis: String,
    /// Thickness of each end's slab as a fraction of the object's extent
    /// along the axis. Default 0.1.
    pub slab: f64,
    /// Speed of each end, in object lengths per second. Default 0.05.
    pub speed: f64,
    /// Seconds over which the speed (or force) ramps up from zero, so
    /// nothing jumps. Default 0.5.
    pub ramp: f64,
    /// Velocity or force. Default velocity.
    pub mode: PullMode,
    /// With `mode = "force"`: traction on each end in Pa. Default 0.
    pub force: f64,
    /// The run ends when the ends have moved apart by this fraction of the
    /// object's length. Default 0.5.
    pub distance: f64,
}

impl Default for Pull {
    fn default() -> Self {
        Pull {
            axis: "long".into(),
            slab: 0.1,
            speed: 0.05,
            ramp: 0.5,
            mode: PullMode::Velocity,
            force: 0.0,
            distance: 0.5,
        }
    }
}

impl Pull {
    /// The pull's axis (0, 1, 2) for material spanning `lo..hi`.
    pub fn axis_index(&self, lo: [f64; 3], hi: [f64; 3]) -> usize {
        match self.axis.as_str() {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => (0..3)
                .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])).then(b.cmp(&a)))
                .unwrap_or(0),
        }
    }

    /// -1 for the nodes of the low end's slab, +1 for the high end's, 0
    /// elsewhere: nodes of the material (in a tetrahedron with some inside)
    /// whose rest position lies within `slab` of the material's extent;
    /// with the axis and the slab's thickness.
    pub fn slabs(
        &self,
        x: &[[f64; 3]],
        phi: &[f64],
        node_tets: &[Vec<(u32, u8)>],
    ) -> (Vec<i8>, usize, f64) {
        let (lo, hi) = material_bounds(x, phi);
        let a = self.axis_index(lo, hi);
        let band = self.slab * (hi[a] - lo[a]);
        let sides = x
            .iter()
            .zip(node_tets)
            .map(|(p, t)| {
                if t.is_empty() {
                    0
                } else if p[a] <= lo[a] + band {
                    -1
                } else if p[a] >= hi[a] - band {
                    1
                } else {
                    0
                }
            })
            .collect();
        (sides, a, band)
    }
}

/// The bounding box of the nodes inside the material (`phi < 0`).
fn material_bounds(x: &[[f64; 3]], phi: &[f64]) -> ([f64; 3], [f64; 3]) {
    let inside: Vec<[f64; 3]> = x
        .iter()
        .zip(phi)
        .filter(|(_, &p)| p < 0.0)
        .map(|(x, _)| *x)
        .collect();
    super::grid::bounds(&inside)
}

/// The pulled nodes when the grips are named faces of the surface (the
/// pipeline's `[select] fix` groups), not slabs: every node of the
/// material within `band` (metres) of a grip face, moved with that face's
/// side: -1 when the face's centre lies below the material's centre along
/// the axis, +1 above. Returns the sides, the axis and `band`.
///
/// # Errors
/// No grip face, or grips only on one side of the centre (nothing would be
/// pulled apart).
pub fn grip_sides(
    pull: &Pull,
    x: &[[f64; 3]],
    phi: &[f64],
    node_tets: &[Vec<(u32, u8)>],
    surface: (&[[f64; 3]], &[[u32; 3]]),
    grips: &[bool],
    band: f64,
) -> Result<(Vec<i8>, usize, f64), GripError> {
    use crate::mesh::spatial::{bbox, closest_on_triangle, dist2, Grid};
    let (positions, triangles) = surface;
    let (lo, hi) = material_bounds(x, phi);
    let a = pull.axis_index(lo, hi);
    let centre = 0.5 * (lo[a] + hi[a]);
    let faces: Vec<[[f64; 3]; 3]> = triangles
        .iter()
        .zip(grips)
        .filter(|(_, &g)| g)
        .map(|(t, _)| t.map(|i| positions[i as usize]))
        .collect();
    if faces.is_empty() {
        return Err(GripError::NoFaces);
    }
    let side_of = |t: &[[f64; 3]; 3]| {
        if (t[0][a] + t[1][a] + t[2][a]) / 3.0 < centre {
            -1i8
        } else {
            1
        }
    };
    let sides_present = [-1i8, 1].map(|s| faces.iter().any(|t| side_of(t) == s));
    if !(sides_present[0] && sides_present[1]) {
        return Err(GripError::OneSide {
            axis: ["x", "y", "z"][a],
        });
    }
    let grid = Grid::new(faces.iter().map(|t| bbox(t)), band);
    let sides = x
        .iter()
        .zip(node_tets)
        .map(|(p, t)| {
            if t.is_empty() {
                return 0;
            }
            let mut best: Option<(f64, usize)> = None;
            grid.search(*p, |f| {
                let d = dist2(*p, closest_on_triangle(*p, faces[f]).0);
                if best.is_none_or(|b| d < b.0 || (d == b.0 && f < b.1)) {
                    best = Some((d, f));
                }
                best.map(|b| b.0)
            });
            match best {
                Some((d, f)) if d <= band * band => side_of(&faces[f]),
                _ => 0,
            }
        })
        .collect();
    Ok((sides, a, band))
}

/// Parameters of the ductile model.
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DuctileParams {
    /// Grid cubes along the object's longest side. Default 40.
    pub grid: usize,
    /// Grid cube side in scene units (overrides `grid` when positive).
    pub cell_size: f64,
    /// The object's longest side in metres (the scene's unit is not
    /// used). Default 0.1.
    pub size: f64,
    /// Young's modulus, Pa. Default 200,000 (a soft clay).
    pub young: f64,
    /// Poisson's ratio, in [0, 0.5). Default 0.3.
    pub poisson: f64,
    /// Density, kg/m^3. Default 1,500.
    pub density: f64,
    /// Fracture resistance `kappa`: the strain-energy density (J/m^3) a
    /// node must exceed to tear. Default 2,000.
    pub kappa: f64,
    /// How fast the torn front moves where the energy is twice `kappa`, in
    /// object lengths per second. Default 1.
    pub tear_speed: f64,
    /// Width of the level set's smoothed delta as a fraction of the grid
    /// spacing. Default 0.5.
    pub eps: f64,
    /// Mass-proportional damping, 1/s. Default 2.
    pub damping: f64,
    /// Stiffness-proportional damping, s. Default 0.001.
    pub stiffness_damping: f64,
    /// Largest time step, s. Default 0.05.
    pub dt: f64,
    /// CFL number: no material (a node inside, or where the surface
    /// crosses an edge) moves more than this many cells an elastic step.
    /// Default 0.5.
    pub cfl: f64,
    /// Most cells the torn front advances during one elastic step (each
    /// node's level set integrated exactly over it, the elastic state
    /// held; nodes left with under a hundredth of a cube of material do
    /// not bound it). Default 4.
    pub tear_cells: f64,
    /// CG tolerance (relative residual). Default 1e-6.
    pub tolerance: f64,
    /// Most CG iterations a step. Default 2,000.
    pub max_cg: usize,
    /// Precondition the CG by a multigrid V-cycle (else by the stiffness'
    /// diagonal, as a reference). Default true.
    pub multigrid: bool,
    /// Keep the level set inside a distance to the torn surface (the
    /// text's step 4, see `redistance.rs`), so a crack crosses a section
    /// at the same speed on any grid; false: the distance to the input's
    /// surface throughout, as a reference. Default true.
    pub redistance: bool,
    /// Virtual nodes: a grid node around which the tear has separated the
    /// material is duplicated, one copy per side (see `virtual_nodes.rs`),
    /// so pieces apart share no node; false: pieces stay tied through the
    /// grid nodes of a gap narrower than a cube, as a reference. Default
    /// true.
    pub virtual_nodes: bool,
    /// Radius (metres) of the nonlocal average through which the level set
    /// reads the strain-energy density where no tear has started yet: each
    /// node's energy is the mean of the nodes' around it, weighted by their
    /// material and a tent of this radius along each axis, so where and
    /// when a tear starts does not follow the grid (a notch's tip is a
    /// singularity, whose peak energy grows as the grid refines). Beside
    /// material already torn the front runs on each node's own energy.
    /// 0: each node's own everywhere (the text's). Default 0.02.
    pub nonlocal: f64,
    /// Passes relaxing the extracted torn surface (its vertices off the
    /// original surface, each within a cube of where it was cut, see
    /// `surface.rs`), turning the grid's terraces where the tear steps
    /// between layers of nodes into the slope they stand for; 0: none.
    /// Default 20.
    pub smooth_tear: usize,
    /// Most steps. Default 10,000.
    pub max_steps: usize,
    /// The pull.
    pub pull: Pull,
    /// Material of the torn surface (made plain when the asset has none
    /// of that name). Default `tear_interior`.
    pub tear_material: String,
}

impl Default for DuctileParams {
    fn default() -> Self {
        DuctileParams {
            grid: 40,
            cell_size: 0.0,
            size: 0.1,
            young: 2e5,
            poisson: 0.3,
            density: 1500.0,
            kappa: 2000.0,
            tear_speed: 1.0,
            eps: 0.5,
            damping: 2.0,
            stiffness_damping: 1e-3,
            dt: 0.05,
            cfl: 0.5,
            tear_cells: 4.0,
            tolerance: 1e-6,
            max_cg: 2000,
            multigrid: true,
            redistance: true,
            virtual_nodes: true,
            nonlocal: 0.02,
            smooth_tear: 20,
            max_steps: 10_000,
            pull: Pull::default(),
            tear_material: "tear_interior".into(),
        }
    }
}

impl DuctileParams {
    /// Grid cubes along a longest side of `longest` scene units.
    pub fn cells_along_longest(&self, longest: f64) -> usize {
        if self.cell_size > 0.0 {
            (longest / self.cell_size).round().max(2.0) as usize
        } else {
            self.grid.max(2)
        }
    }

    /// Check every value, naming the one that is wrong.
    ///
    /// # Errors
    /// A [`ParamError`] naming the parameter.
    pub fn validate(&self) -> Result<(), ParamError> {
        let pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(ParamError::range(
                    format!("ductile.{name}"),
                    "a positive number",
                    x,
                ))
            }
        };
        let non_neg = |name: &str, x: f64| {
            if x.is_finite() && x >= 0.0 {
                Ok(())
            } else {
                Err(ParamError::range(
                    format!("ductile.{name}"),
                    "zero or positive",
                    x,
                ))
            }
        };
        if !(2..=super::MAX_CELLS_ALONG).contains(&self.grid) {
            return Err(ParamError::range(
                "ductile.grid",
                format!("in 2..={}", super::MAX_CELLS_ALONG),
                self.grid,
            ));
        }
        // Upper bounds keep every product of the material's numbers (energy
        // densities, wave speeds, the front's rate) finite and the time step
        // a step the run can take: no solid is stiffer than 1e13 Pa (diamond
        // 1.2e12), denser than 1e5 kg/m^3 (osmium 2.3e4) or lighter than
        // 0.1 kg/m^3 (aerogel about 1).
        let within = |name: &str, x: f64, lo: f64, hi: f64, unit: &str| {
            if x.is_finite() && x >= lo && x <= hi {
                Ok(())
            } else {
                Err(ParamError::range(
                    format!("ductile.{name}"),
                    format!("in [{lo:e}, {hi:e}] {unit}"),
                    x,
                ))
            }
        };
        non_neg("cell_size", self.cell_size)?;
        within("size", self.size, 1e-6, 1e6, "m")?;
        within("young", self.young, 1e-3, 1e13, "Pa")?;
        if !(self.poisson.is_finite() && (0.0..0.5).contains(&self.poisson)) {
            return Err(ParamError::range(
                "ductile.poisson",
                "in [0, 0.5)",
                self.poisson,
            ));
        }
        within("density", self.density, 0.1, 1e5, "kg/m^3")?;
        within("kappa", self.kappa, 1e-9, 1e20, "J/m^3")?;
        within("tear_speed", self.tear_speed, 1e-9, 1e3, "lengths/s")?;
        pos("eps", self.eps)?;
        non_neg("damping", self.damping)?;
        non_neg("stiffness_damping", self.stiffness_damping)?;
        pos("dt", self.dt)?;
        pos("cfl", self.cfl)?;
        pos("tear_cells", self.tear_cells)?;
        within("nonlocal", self.nonlocal, 0.0, 1e3, "m")?;
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(ParamError::range(
                "ductile.tolerance",
                "in (0, 1)",
                self.tolerance,
            ));
        }
        if self.max_cg == 0 || self.max_steps == 0 {
            return Err(ParamError::invalid(
                "ductile.max_cg and ductile.max_steps",
                "must be at least 1",
            ));
        }
        if self.tear_material.is_empty() {
            return Err(ParamError::invalid(
                "ductile.tear_material",
                "must not be empty",
            ));
        }
        let p = &self.pull;
        if !["x", "y", "z", "long"].contains(&p.axis.as_str()) {
            return Err(ParamError::range(
                "ductile.pull.axis",
                "\"x\", \"y\", \"z\" or \"long\"",
                format!("{:?}", p.axis),
            ));
        }
        if !(p.slab > 0.0 && p.slab < 0.5) {
            return Err(ParamError::range(
                "ductile.pull.slab",
                "in (0, 0.5)",
                p.slab,
            ));
        }
        non_neg("pull.speed", p.speed)?;
        non_neg("pull.ramp", p.ramp)?;
        non_neg("pull.force", p.force)?;
        pos("pull.distance", p.distance)?;
        match p.mode {
            PullMode::Velocity => pos("pull.speed", p.speed),
            PullMode::Force => pos("pull.force", p.force),
        }
    }
}
