//! How a simulation is computed: a physical [`Model`] (the course model, the stable
//! fluidanimate variant, or the weakly compressible model) and a [`Kernel`] (plain scalar
//! loops, `f64x4` or `f64x8` lanes, mixed f64/f32 lanes, or the compensated reference)
//! that runs its pair interactions.

use crate::sim::kernel::Kernel;
use crate::sim::model::Model;

/// A model and a kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Method {
    /// The physical model.
    pub model: Model,
    /// The pair-loop implementation.
    pub kernel: Kernel,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_names_follow_the_variants_and_the_command_line() {
        use clap::ValueEnum;
        assert_eq!(
            Kernel::ALL.map(Kernel::name),
            ["scalar", "simd", "simd8", "mixed", "reference"]
        );
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
