//! How a simulation is computed: which model (the course model, the stable
//! fluidanimate variant, or the weakly compressible model) and which kernel (plain scalar
//! loops, `f64x4` or `f64x8` lanes, mixed f64/f32 lanes, or the compensated reference)
//! runs the pair interactions.

use crate::sim::params::TIME_STEP;
use crate::sim::timestep::TimeStep;

/// The physical model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum Model {
    /// The course model of SPEC.md: viscosity `(v_j - v_i) * 45/(pi h^6) * mu * m`.
    /// Unstable (the fluid leaves the box within a few steps); `fluid` always runs it.
    #[default]
    Course,
    /// The PARSEC fluidanimate variant: the viscosity term is also multiplied by
    /// `(h - dist)`, which keeps the fluid in the box.
    Fluidanimate,
    /// Weakly compressible SPH as the validated codes run water (`sim::wcsph`): Tait's
    /// equation of state (gamma 7, sound speed ten times the fastest fall), density by
    /// the continuity equation with delta-SPH, Monaghan's viscosity, the Wendland kernel
    /// (support 2.6 spacings), free-slip mirror walls, and a CFL time step by default.
    Wcsph,
}

/// The implementation of the pair loops (density increment, acceleration transfer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Kernel {
    /// One pair at a time in plain f64: the reference path.
    Scalar,
    /// Four partners at a time in `wide::f64x4` lanes, with masks for the cut-off and the
    /// tail lanes.
    Simd,
    /// As [`Kernel::Simd`], eight partners at a time in `wide::f64x8` lanes (one AVX-512
    /// register; two AVX2 registers elsewhere).
    Simd8,
    /// Mixed precision, eight partners at a time: each pair's differences computed in f64
    /// and narrowed to f32, the pair terms in `wide::f32x8` lanes, the sums in f64. Not
    /// held to the reference outputs (within 5e-7 relative on a dense step); a workbench method.
    Mixed,
    /// Each particle's sums on their own, over its partners in id order, with compensated
    /// (Neumaier) summation: the reference trajectory for accuracy measurements (slow).
    Reference,
}

/// A model and a kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Method {
    /// The physical model.
    pub model: Model,
    /// The pair-loop implementation.
    pub kernel: Kernel,
}

impl Model {
    /// Every model, in a fixed order.
    pub const ALL: [Model; 3] = [Model::Course, Model::Fluidanimate, Model::Wcsph];

    /// The model's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Model::Course => "course",
            Model::Fluidanimate => "fluidanimate",
            Model::Wcsph => "wcsph",
        }
    }

    /// The time-step rule the model runs with unless told otherwise: the course's fixed
    /// 1 ms, or for the stiff weakly compressible model its CFL step.
    pub fn default_time_step(self) -> TimeStep {
        match self {
            Model::Course | Model::Fluidanimate => TimeStep::Fixed(TIME_STEP),
            Model::Wcsph => TimeStep::Adaptive {
                courant: crate::sim::wcsph::COURANT,
            },
        }
    }
}

impl Kernel {
    /// Every kernel, in a fixed order.
    pub const ALL: [Kernel; 5] = [
        Kernel::Scalar,
        Kernel::Simd,
        Kernel::Simd8,
        Kernel::Mixed,
        Kernel::Reference,
    ];

    /// The kernels that compute in f64 throughout, held to the reference outputs.
    pub const F64: [Kernel; 4] = [
        Kernel::Scalar,
        Kernel::Simd,
        Kernel::Simd8,
        Kernel::Reference,
    ];

    /// The kernels meant for speed (the reference is meant for accuracy).
    pub const FAST: [Kernel; 4] = [Kernel::Scalar, Kernel::Simd, Kernel::Simd8, Kernel::Mixed];

    /// The fastest f64 kernel for the CPU the crate is built for: [`Kernel::Simd8`] where
    /// AVX-512 is enabled, [`Kernel::Simd`] otherwise. `fluid` runs it.
    pub const NATIVE: Kernel = if cfg!(target_feature = "avx512f") {
        Kernel::Simd8
    } else {
        Kernel::Simd
    };

    /// The kernel's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Simd => "simd",
            Kernel::Simd8 => "simd8",
            Kernel::Mixed => "mixed",
            Kernel::Reference => "reference",
        }
    }
}

impl Default for Kernel {
    /// [`Kernel::NATIVE`].
    fn default() -> Self {
        Kernel::NATIVE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_variants_and_the_command_line() {
        use clap::ValueEnum;
        assert_eq!(
            Model::ALL.map(Model::name),
            ["course", "fluidanimate", "wcsph"]
        );
        assert_eq!(
            Kernel::ALL.map(Kernel::name),
            ["scalar", "simd", "simd8", "mixed", "reference"]
        );
        for model in Model::ALL {
            assert_eq!(model.to_possible_value().unwrap().get_name(), model.name());
        }
        for kernel in Kernel::ALL {
            assert_eq!(
                kernel.to_possible_value().unwrap().get_name(),
                kernel.name()
            );
        }
    }

    #[test]
    fn the_default_is_the_course_model_on_the_widest_lanes_the_cpu_has() {
        let method = Method::default();
        assert_eq!(method.model, Model::Course);
        let wide = std::arch::is_x86_feature_detected!("avx512f");
        let expected = if cfg!(target_feature = "avx512f") && wide {
            Kernel::Simd8
        } else {
            Kernel::Simd
        };
        assert_eq!(method.kernel, expected);
    }
}
