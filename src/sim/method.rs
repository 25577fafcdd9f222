//! How a simulation is computed: which model (the course model or the stable
//! fluidanimate variant) and which kernel (plain scalar loops, `f64x4` lanes, or the
//! compensated reference) runs the pair interactions.

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
}

/// The implementation of the pair loops (density increment, acceleration transfer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, clap::ValueEnum)]
pub enum Kernel {
    /// One pair at a time in plain f64: the reference path.
    Scalar,
    /// Four partners at a time in `wide::f64x4` lanes, with masks for the cut-off and the
    /// tail lanes.
    #[default]
    Simd,
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
    pub const ALL: [Model; 2] = [Model::Course, Model::Fluidanimate];

    /// The model's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Model::Course => "course",
            Model::Fluidanimate => "fluidanimate",
        }
    }
}

impl Kernel {
    /// Every kernel, in a fixed order.
    pub const ALL: [Kernel; 3] = [Kernel::Scalar, Kernel::Simd, Kernel::Reference];

    /// The kernels meant for speed (the reference is meant for accuracy).
    pub const FAST: [Kernel; 2] = [Kernel::Scalar, Kernel::Simd];

    /// The kernel's name in benchmark labels, command lines and CSV files.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Scalar => "scalar",
            Kernel::Simd => "simd",
            Kernel::Reference => "reference",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_variants_and_the_command_line() {
        use clap::ValueEnum;
        assert_eq!(Model::ALL.map(Model::name), ["course", "fluidanimate"]);
        assert_eq!(
            Kernel::ALL.map(Kernel::name),
            ["scalar", "simd", "reference"]
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
    fn the_default_is_the_course_model_on_simd_lanes() {
        let method = Method::default();
        assert_eq!((method.model, method.kernel), (Model::Course, Kernel::Simd));
    }
}
