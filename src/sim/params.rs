//! The course model's constants (SPEC.md section 3, with the errata of section 7) and the
//! values derived from an input's particles per metre.

use glam::DVec3;
use std::f64::consts::PI;

/// Smoothing-length multiplier r: h = r / ppm.
pub const RADIUS_MULTIPLIER: f64 = 1.695;
/// Rest density of the fluid, rho_f (kg/m^3).
pub const FLUID_DENSITY: f64 = 1e3;
/// Pressure stiffness p_s.
pub const PRESSURE_STIFFNESS: f64 = 3.0;
/// Wall collision stiffness s_c.
pub const COLLISION_STIFFNESS: f64 = 3e4;
/// Wall damping d_v.
pub const DAMPING: f64 = 128.0;
/// Viscosity mu.
pub const VISCOSITY: f64 = 0.4;
/// Particle size d_p used by the wall collisions.
pub const PARTICLE_SIZE: f64 = 2e-4;
/// Time step dt (s).
pub const TIME_STEP: f64 = 1e-3;
/// Gravity (erratum 2: pointing down).
pub const GRAVITY: DVec3 = DVec3::new(0.0, -9.8, 0.0);
/// Lower corner of the box (erratum 1).
pub const BOX_MIN: DVec3 = DVec3::new(-0.065, -0.08, -0.065);
/// Upper corner of the box (erratum 1).
pub const BOX_MAX: DVec3 = DVec3::new(0.065, 0.1, 0.065);
/// The box the particles live in and the gravity that acts on them: SPEC.md's
/// ([`Domain::COURSE`]) for the course model and every `.fld` run; a case file's for the
/// workbench's other models.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    /// The box's low corner (m).
    pub min: DVec3,
    /// The box's high corner (m).
    pub max: DVec3,
    /// Gravity (m/s^2).
    pub gravity: DVec3,
    /// A two-dimensional scene: every particle in the plane z = 0 with no motion along
    /// z, the box's z walls absent, and the water model's kernel and mass per unit depth
    /// (its z extent is a slab one lattice spacing deep, which exports and renders show).
    pub planar: bool,
    /// The axes whose two faces are periodic: a particle leaving through one comes in at
    /// the other, and pairs are found across them (the water model's).
    pub periodic: [bool; 3],
}

impl Default for Domain {
    fn default() -> Domain {
        Domain::COURSE
    }
}

impl Domain {
    /// SPEC.md's box and gravity.
    pub const COURSE: Domain = Domain {
        min: BOX_MIN,
        max: BOX_MAX,
        gravity: GRAVITY,
        planar: false,
        periodic: [false; 3],
    };

    /// The box's edge lengths (m).
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// g, if gravity is [0, -g, 0] with g > 0: down y, as a floor at the box's low y wall
    /// and hydrostatics along y need it.
    pub fn downward_pull(&self) -> Option<f64> {
        let DVec3 { x, y, z } = self.gravity;
        (x == 0.0 && z == 0.0 && y < 0.0).then_some(-y)
    }

    /// This box's x-y section as a planar domain at `ppm` particles per metre: the slab one
    /// lattice spacing deep around the plane z = 0 (as a 2-D case's).
    pub fn section(self, ppm: f64) -> Domain {
        let half = 0.5 * (1.0 / ppm);
        Domain {
            min: DVec3::new(self.min.x, self.min.y, -half),
            max: DVec3::new(self.max.x, self.max.y, half),
            planar: true,
            ..self
        }
    }

    /// The number of dimensions the particles move in: 2 ([`Self::planar`]) or 3.
    pub fn dimensions(&self) -> usize {
        if self.planar {
            2
        } else {
            3
        }
    }

    /// Whether `p` is inside the box, walls included.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// Smallest squared distance used in the acceleration transfer (avoids division by zero).
pub const MIN_DISTANCE_SQUARED: f64 = 1e-12;

/// Values derived from the particles per metre, computed once per run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Particles per metre, as read (widened from f32).
    pub ppm: f64,
    /// Smoothing length h of the course models: the pair cut-off (for the weakly
    /// compressible model, whose own constants are in [`crate::sim::model::wcsph`], its
    /// kernel's support radius).
    pub h: f64,
    /// h^2, the squared cut-off distance.
    pub h2: f64,
    /// h^6, added to each raw density sum (the particle's own contribution).
    pub h6: f64,
    /// Particle mass m = rho_f / ppm^3 (erratum 3).
    pub mass: f64,
    /// Density transform factor 315 / (64 pi h^9) * m.
    pub density_factor: f64,
    /// Pressure factor 15 / (pi h^6) * (3 m p_s / 2) (erratum 4).
    pub pressure_factor: f64,
    /// Viscosity factor 45 / (pi h^6) * mu * m.
    pub viscosity_factor: f64,
    /// Time step dt ([`TIME_STEP`] in the course model; the workbench can change it).
    pub dt: f64,
    /// The box and gravity ([`Domain::COURSE`] unless a case gives its own).
    pub domain: Domain,
}

impl Params {
    /// Derives every parameter from the particles per metre (which must be finite and > 0).
    pub fn new(ppm: f64) -> Self {
        Self::with_cutoff(ppm, RADIUS_MULTIPLIER / ppm)
    }

    /// As [`Self::new`], with the cut-off `h` (m) of another model
    /// ([`crate::sim::model::Model::params`]).
    pub fn with_cutoff(ppm: f64, h: f64) -> Self {
        let h2 = h * h;
        let h6 = h2 * h2 * h2;
        let mass = FLUID_DENSITY / ppm.powi(3);
        Self {
            ppm,
            h,
            h2,
            h6,
            mass,
            density_factor: 315.0 / (64.0 * PI * h.powi(9)) * mass,
            pressure_factor: 15.0 / (PI * h6) * (3.0 * mass * PRESSURE_STIFFNESS / 2.0),
            viscosity_factor: 45.0 / (PI * h6) * VISCOSITY * mass,
            dt: TIME_STEP,
            domain: Domain::COURSE,
        }
    }

    /// These parameters in `domain`.
    pub fn within(self, domain: Domain) -> Self {
        Self { domain, ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
    }

    #[test]
    fn small_input_parameters() {
        let p = Params::new(204.0);
        assert!(close(p.h, 0.008308823529411764));
        assert!(close(p.mass, 1000.0 / 8_489_664.0));
        assert!(close(p.h6, p.h.powi(6)));
    }

    #[test]
    fn a_pull_down_y_is_the_only_downward_one() {
        assert_eq!(Domain::COURSE.downward_pull(), Some(9.8));
        let with = |gravity: DVec3| Domain {
            gravity,
            ..Domain::COURSE
        };
        assert_eq!(
            with(DVec3::new(0.0, -0.01, 0.0)).downward_pull(),
            Some(0.01)
        );
        for gravity in [
            DVec3::ZERO,
            DVec3::new(0.0, 9.8, 0.0),
            DVec3::new(1.0, -9.8, 0.0),
        ] {
            assert_eq!(with(gravity).downward_pull(), None, "{gravity}");
        }
    }

    #[test]
    fn factors_follow_the_corrected_formulas() {
        let p = Params::new(292.0);
        let h9 = p.h.powi(9);
        assert!(close(p.density_factor, 315.0 * p.mass / (64.0 * PI * h9)));
        assert!(close(
            p.pressure_factor,
            45.0 * p.mass * PRESSURE_STIFFNESS / (2.0 * PI * p.h6)
        ));
        assert!(close(
            p.viscosity_factor,
            45.0 * VISCOSITY * p.mass / (PI * p.h6)
        ));
    }
}
