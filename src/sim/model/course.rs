//! The course model of SPEC.md and PARSEC fluidanimate's stable variant: one type,
//! [`Course`], whose `FLUIDANIMATE` flag multiplies the viscosity term by (h - dist). Its
//! constants are SPEC.md's ([`crate::sim::params`], which the door prints and the kernels
//! read); its pair passes are stages 3-5 ([`kernel::Densities`], the density transform
//! and [`kernel::Accelerations`]); its walls and motion stages 6-8 ([`stages`]); its
//! adaptive step the criteria below. Its densities are recomputed every step, and a
//! checkpoint keeps nothing of it beyond the particles.

use super::{Context, Dynamics, Partnerless};
use crate::sim::cells::Walls;
use crate::sim::kernel::{self, Accelerations, Candidates, ClosePairs, Densities, Packed};
use crate::sim::params::{
    Params, COLLISION_STIFFNESS, DAMPING, FLUID_DENSITY, PRESSURE_STIFFNESS, RADIUS_MULTIPLIER,
    TIME_STEP,
};
use crate::sim::particles::Particles;
use crate::sim::stages::{self, Stage};
use crate::sim::timestep::{largest_acceleration_and_speed, Leapfrog, Limit, TimeStep};
use std::f64::consts::PI;

/// The course model (`FLUIDANIMATE` false) or fluidanimate's (true), with where its last
/// density pass found the pairs closer than h, which its acceleration pass then visits.
#[derive(Debug, Clone, Default)]
pub struct Course<const FLUIDANIMATE: bool> {
    /// Where the last density pass found pairs closer than h.
    close: ClosePairs,
    /// The placement ([`Context::placement`]) that pass ran on.
    found_on: Option<u64>,
    /// The copies the SIMD passes read.
    packed: Packed,
}

/// PARSEC fluidanimate's stable variant of the course model.
pub type Fluidanimate = Course<true>;

/// The sound speed of the course models' pressure law p = p_s (rho - rho_0): sqrt(p_s) m/s.
pub fn sound_speed() -> f64 {
    PRESSURE_STIFFNESS.sqrt()
}

/// The explicit stability limit of the walls' penalty (s): min(2 / d_v, 2 / sqrt(s_c)).
pub fn walls_limit() -> f64 {
    (2.0 / DAMPING).min(2.0 / COLLISION_STIFFNESS.sqrt())
}

impl<const FLUIDANIMATE: bool> Course<FLUIDANIMATE> {
    /// The rate (1/s) at which the viscosity damps a particle's velocity relative to its
    /// neighbours' in fluid at rest: each pair adds viscosity_factor * w / (rho_i rho_j)
    /// times the velocity difference, w = 1 (course) or h - r <= h (fluidanimate), and a
    /// particle at rest has (4/3) pi (h ppm)^3 = 20.4 neighbours within h. An explicit
    /// step is stable below about 2 / rate: for the course model 0.4 ms at 100 particles
    /// per metre and 15 us at 300, for fluidanimate 24 and 2.7 ms (the stability map's
    /// limits).
    pub fn viscous_rate(params: &Params) -> f64 {
        let neighbours = 4.0 / 3.0 * PI * (params.h * params.ppm).powi(3);
        let weight = if FLUIDANIMATE { params.h } else { 1.0 };
        neighbours * params.viscosity_factor * weight / (FLUID_DENSITY * FLUID_DENSITY)
    }

    /// The adaptive step of a state whose accelerations (pairs and gravity, stages 2-5)
    /// are computed: C * min(min_i sqrt(h / |a_i|), h / (c + max_i |hv_i|), 2 / lambda,
    /// walls) with lambda the [`Self::viscous_rate`] and walls = min(2 / d_v,
    /// 2 / sqrt(s_c)) = 11.5 ms, and the criterion that set it. The last two are explicit
    /// stability limits. Non-finite values are skipped (the run's own checks report them).
    pub fn step_for(params: &Params, particles: &Particles, courant: f64) -> (f64, Limit) {
        let (acceleration, speed) = largest_acceleration_and_speed(particles);
        let criteria = [
            (
                (params.h / acceleration).sqrt(), // infinite without accelerations
                Limit::Force,
            ),
            (params.h / (sound_speed() + speed), Limit::Speed),
            (2.0 / Self::viscous_rate(params), Limit::Viscosity),
            (walls_limit(), Limit::Walls),
        ];
        let (scale, limit) =
            criteria
                .into_iter()
                .fold((f64::INFINITY, Limit::Walls), |best, criterion| {
                    if criterion.0 < best.0 {
                        criterion
                    } else {
                        best
                    }
                });
        (courant * scale, limit)
    }
}

impl<const FLUIDANIMATE: bool> Dynamics for Course<FLUIDANIMATE> {
    /// SPEC.md's: the stiffness times the density's excess over the rest density, the
    /// pressure its acceleration's factor (rho_i + rho_j - 2 rho_0) sums in pairs.
    fn pressure(&self, density: f64) -> f64 {
        PRESSURE_STIFFNESS * (density - FLUID_DENSITY)
    }

    fn cutoff(&self, ppm: f64) -> f64 {
        RADIUS_MULTIPLIER / ppm
    }

    fn default_time_step(&self) -> TimeStep {
        TimeStep::Fixed(TIME_STEP)
    }

    fn interact(&mut self, context: &mut Context) {
        for stage in [
            Stage::IncrementDensities,
            Stage::TransformDensities,
            Stage::TransferAccelerations,
        ] {
            self.run_stage(stage, context);
        }
    }

    fn partnerless(&self, params: &Params) -> Option<Partnerless> {
        // Stage 2's density, transformed as every particle's is (stage 4), and gravity.
        let mut density = [0.0];
        kernel::transform_densities(params, &mut density);
        Some(Partnerless {
            density: density[0],
            acceleration: params.domain.gravity,
        })
    }

    fn refresh_densities(&mut self, context: &mut Context) {
        self.run_stage(Stage::IncrementDensities, context);
        self.run_stage(Stage::TransformDensities, context);
    }

    fn adaptive_step(&self, params: &Params, particles: &Particles, courant: f64) -> (f64, Limit) {
        Self::step_for(params, particles, courant)
    }

    fn advance(&mut self, step: Leapfrog, walls: &Walls, particles: &mut Particles) {
        stages::advance(walls, step, particles);
    }

    fn run_stage(&mut self, stage: Stage, context: &mut Context) {
        let Context {
            params,
            kernel,
            tiles,
            lists,
            walls,
            placement,
            ref mut particles,
            ..
        } = *context;
        let n = particles.len();
        match stage {
            Stage::Reposition | Stage::InitAccelerations => {}
            Stage::IncrementDensities => {
                let Particles { id, p, rho, .. } = &mut **particles;
                kernel.run(Densities {
                    params,
                    tiles,
                    lists,
                    p,
                    id,
                    rho,
                    close: &mut self.close,
                    packed: &mut self.packed,
                });
                self.found_on = Some(placement);
            }
            Stage::TransformDensities => {
                kernel::transform_densities(params, &mut particles.rho[..n])
            }
            Stage::TransferAccelerations => {
                let candidates = if self.found_on == Some(placement) {
                    Candidates::Close(&self.close)
                } else {
                    Candidates::All(tiles)
                };
                let Particles {
                    id, p, v, rho, a, ..
                } = &mut **particles;
                kernel.run(Accelerations::<FLUIDANIMATE> {
                    params,
                    candidates,
                    lists,
                    p,
                    v,
                    rho,
                    id,
                    a,
                    packed: &mut self.packed,
                });
            }
            Stage::CollideWithWalls => stages::collide_with_walls(walls, params.dt, particles),
            Stage::Move => stages::move_particles(params.dt, particles),
            Stage::InteractWithBoundary => stages::interact_with_boundary(walls, particles),
        }
    }

    fn heap_bytes(&self) -> usize {
        self.close.heap_bytes() + self.packed.heap_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::timestep::Integrator;

    type Spec = Course<false>;

    fn particles_with(a: [f64; 3], hv: [f64; 3]) -> Particles {
        let mut particles = Particles::zeroed(2);
        for axis in 0..3 {
            particles.a[axis][1] = a[axis];
            particles.hv[axis][1] = hv[axis];
        }
        particles
    }

    #[test]
    fn each_criterion_can_set_the_step() {
        let params = Params::new(200.0);
        let c = sound_speed();
        // At rest with gravity only: the acoustic time h / c is the shortest.
        let rest = particles_with([0.0, -9.8, 0.0], [0.0; 3]);
        let (dt, limit) = Fluidanimate::step_for(&params, &rest, 0.3);
        assert_eq!(limit, Limit::Speed);
        assert!((dt - 0.3 * params.h / c).abs() < 1e-15);
        // A violent state: |a| = 5e4 m/s^2 gives sqrt(h / |a|) well below h / c.
        let violent = particles_with([3e4, -4e4, 0.0], [1.0, 0.0, 0.0]);
        let (dt, limit) = Fluidanimate::step_for(&params, &violent, 0.25);
        assert_eq!(limit, Limit::Force);
        assert!((dt - 0.25 * (params.h / 5e4).sqrt()).abs() < 1e-15);
        // Fast particles shorten the acoustic time.
        let fast = particles_with([0.0; 3], [0.0, 0.0, 10.0]);
        let (dt, limit) = Fluidanimate::step_for(&params, &fast, 1.0);
        assert_eq!(limit, Limit::Speed);
        assert!((dt - params.h / (c + 10.0)).abs() < 1e-15);
        // The course model's viscosity, and fluidanimate's at finer resolution.
        let params = Params::new(200.0);
        let (dt, limit) = Spec::step_for(&params, &rest, 0.3);
        assert_eq!(limit, Limit::Viscosity, "the course model at 200");
        assert!((dt - 0.6 / Spec::viscous_rate(&params)).abs() < 1e-15);
        let params = Params::new(292.0);
        let (dt, limit) = Fluidanimate::step_for(&params, &rest, 0.3);
        assert_eq!(limit, Limit::Viscosity, "fluidanimate at 292");
        assert!((dt - 0.6 / Fluidanimate::viscous_rate(&params)).abs() < 1e-15);
        // Coarse particles at rest: the walls' limit is the shortest.
        let coarse = Params::new(40.0);
        let (dt, limit) = Fluidanimate::step_for(&coarse, &particles_with([0.0; 3], [0.0; 3]), 0.5);
        assert_eq!(limit, Limit::Walls);
        assert_eq!(dt, 0.5 * walls_limit());
        assert!((walls_limit() - 2.0 / COLLISION_STIFFNESS.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn a_particle_without_a_partner_gets_what_partnerless_says() {
        use crate::sim::kernel::Kernel;
        use crate::sim::method::Method;
        use crate::sim::model::Model;
        use crate::sim::simulation::Simulation;
        // Three particles 2 cm apart (h is 8.3 mm), moving: none has a partner.
        let mut particles = Particles::zeroed(3);
        for slot in 0..3 {
            particles.p[0][slot] = 0.02 * slot as f64;
            particles.v[1][slot] = slot as f64;
        }
        for model in [Model::Course, Model::Fluidanimate] {
            let mut sim = Simulation::with_method(
                204.0,
                particles.clone(),
                Method {
                    model,
                    kernel: Kernel::Simd,
                },
            )
            .unwrap();
            for stage in &Stage::ALL[..5] {
                sim.run_stage(*stage);
            }
            let expected = model.dynamics().partnerless(sim.params()).unwrap();
            // (0 + h^6) 315 / (64 pi h^9) m, a particle's own share of its density.
            let own = 315.0 / (64.0 * PI * sim.params().h.powi(3)) * sim.params().mass;
            assert!((expected.density / own - 1.0).abs() < 1e-12);
            for slot in 0..3 {
                let found = sim.particles();
                assert_eq!(found.rho[slot].to_bits(), expected.density.to_bits());
                assert_eq!(found.acceleration(slot), expected.acceleration);
            }
        }
        // The water model's lone particles feel its walls where they are: none.
        let params = Model::Wcsph.params(204.0);
        assert!(Model::Wcsph.dynamics().partnerless(&params).is_none());
    }

    #[test]
    fn the_viscous_limit_is_the_stability_maps() {
        // 2 / rate: 0.41 ms for the course model at 100 particles per metre, which is
        // stable at 0.25 ms and fails at 0.5 ms; 2.7 ms for fluidanimate at 300, stable at
        // 2 ms and failing at 4 ms (README's stability map).
        let course = 2.0 / Spec::viscous_rate(&Params::new(100.0));
        assert!((course - 4.06e-4).abs() < 1e-6);
        let stable = 2.0 / Fluidanimate::viscous_rate(&Params::new(300.0));
        assert!((stable - 2.66e-3).abs() < 1e-5);
        let params = Params::new(150.0);
        let ratio = Spec::viscous_rate(&params) / Fluidanimate::viscous_rate(&params);
        assert!((ratio * params.h - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_calm_state_takes_longer_steps_than_a_violent_one() {
        let params = Params::new(200.0);
        let calm = particles_with([0.0, -9.8, 0.0], [0.0; 3]);
        let violent = particles_with([2e3, 0.0, 0.0], [0.0, 3.0, 0.0]);
        let calm = Fluidanimate::step_for(&params, &calm, 0.3).0;
        let violent = Fluidanimate::step_for(&params, &violent, 0.3).0;
        assert!(calm > 2.0 * violent, "{calm} against {violent}");
    }

    #[test]
    fn non_finite_values_do_not_set_the_step() {
        let params = Params::new(200.0);
        let particles = particles_with([f64::NAN, 0.0, 0.0], [f64::INFINITY, 0.0, 0.0]);
        let (dt, limit) = Fluidanimate::step_for(&params, &particles, 0.3);
        assert_eq!(limit, Limit::Speed);
        assert!(dt.is_finite() && dt > 0.0);
    }

    #[test]
    fn the_acceleration_pass_visits_only_the_close_pairs_of_its_placement() {
        use crate::sim::kernel::Kernel;
        use crate::sim::lists::PairStructure;
        use crate::sim::method::Method;
        use crate::sim::model::Model;
        use crate::sim::params::BOX_MIN;
        use crate::sim::simulation::Simulation;
        // Along x: pairs closer than h, pairs in adjacent cells farther than h, and 600
        // particles in one far cell (groups past the overflow bit on 4 and on 8 lanes).
        let mut xs = vec![0.0, 0.004, 0.0075, 0.0165, 0.03, 0.06];
        xs.extend((0..600).map(|k| 50.0 + 1e-6 * k as f64));
        let mut particles = Particles::zeroed(xs.len());
        particles.p[1] = vec![BOX_MIN.y + 0.05; xs.len()];
        particles.p[2] = vec![BOX_MIN.z + 0.05; xs.len()];
        particles.p[0] = xs;
        for kernel in Kernel::ALL {
            let model = Model::Course;
            let mut sim =
                Simulation::with_method(204.0, particles.clone(), Method { model, kernel })
                    .unwrap();
            // On the tiles (the passes on lists are held to the reference outputs in
            // `tests/lab.rs` and to the tiles in `Simulation`'s kept-list test).
            sim.set_pair_structure(PairStructure::Tiles);
            sim.run_stage(Stage::Reposition);
            let (mut close, mut every) = (sim.particles().clone(), sim.particles().clone());
            let mut course = Spec::default();
            let mut run = |stage, placement, particles: &mut Particles| {
                let mut context = Context {
                    params: sim.params(),
                    kernel,
                    tiles: sim.tiles(),
                    lists: None,
                    walls: sim.cells().walls(),
                    placement,
                    integrator: Integrator::Leapfrog,
                    previous_step: None,
                    particles,
                };
                course.run_stage(stage, &mut context);
            };
            run(Stage::IncrementDensities, 1, &mut close);
            run(Stage::TransformDensities, 1, &mut close);
            every.rho.clone_from(&close.rho);
            // The pass of placement 1 visits what the density pass found; that of a later
            // placement, every tile.
            run(Stage::TransferAccelerations, 1, &mut close);
            run(Stage::TransferAccelerations, 2, &mut every);
            assert_eq!(close.a, every.a, "{kernel:?}");
            assert_ne!(close.a[0][0], 0.0);
            let found = course.close.tiles.len();
            assert!(
                found > 0 && found < sim.tiles().len(),
                "{kernel:?}: {found}"
            );
        }
    }
}
