//! Particle state as a structure of arrays: one contiguous `Vec` per field and axis, so the
//! physics loops stream through memory and can be vectorised.

use glam::DVec3;

/// Three arrays, one per axis, of one vector field.
pub type AxisArrays = [Vec<f64>; 3];

/// Extra elements after the last particle in every `f64` array of a simulation's
/// particles, so that eight-lane loads starting at any particle stay in bounds.
pub const PADDING: usize = 7;

/// The state of every particle, stored slot by slot (in cell order during a simulation,
/// with [`PADDING`] extra elements after the last particle).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Particles {
    /// Particle id (its record index in the input file) of each slot.
    pub id: Vec<u32>,
    /// Position p.
    pub p: AxisArrays,
    /// Half-step velocity hv.
    pub hv: AxisArrays,
    /// Velocity v.
    pub v: AxisArrays,
    /// Density rho (raw sums during the density increment).
    pub rho: Vec<f64>,
    /// Acceleration a.
    pub a: AxisArrays,
}

fn zeros(n: usize) -> AxisArrays {
    std::array::from_fn(|_| vec![0.0; n])
}

/// The vector of one slot of a field stored as per-axis arrays.
pub fn vector_at(arrays: &AxisArrays, slot: usize) -> DVec3 {
    DVec3::new(arrays[0][slot], arrays[1][slot], arrays[2][slot])
}

/// `target` made the slots `order` of `source`, padded with zeros.
fn gather_axes(target: &mut AxisArrays, source: &AxisArrays, order: &[u32]) {
    for (t, s) in target.iter_mut().zip(source) {
        t.clear();
        // Room for the padding too, so that it does not grow the array by half or more.
        t.reserve_exact(order.len() + PADDING);
        t.extend(order.iter().map(|&k| s[k as usize]));
        t.resize(order.len() + PADDING, 0.0);
    }
}

impl Particles {
    /// The bytes its arrays hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        use crate::sim::heap_bytes as bytes;
        let axes = |arrays: &AxisArrays| arrays.iter().map(bytes).sum::<usize>();
        bytes(&self.id)
            + axes(&self.p)
            + axes(&self.hv)
            + axes(&self.v)
            + bytes(&self.rho)
            + axes(&self.a)
    }

    /// `n` particles with ids 0..n and every field zero.
    pub fn zeroed(n: usize) -> Self {
        Self {
            id: (0..n as u32).collect(),
            p: zeros(n),
            hv: zeros(n),
            v: zeros(n),
            rho: vec![0.0; n],
            a: zeros(n),
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Position of the particle in `slot`.
    pub fn position(&self, slot: usize) -> DVec3 {
        vector_at(&self.p, slot)
    }

    /// Half-step velocity of the particle in `slot`.
    pub fn half_velocity(&self, slot: usize) -> DVec3 {
        vector_at(&self.hv, slot)
    }

    /// Velocity of the particle in `slot`.
    pub fn velocity(&self, slot: usize) -> DVec3 {
        vector_at(&self.v, slot)
    }

    /// Acceleration of the particle in `slot`.
    pub fn acceleration(&self, slot: usize) -> DVec3 {
        vector_at(&self.a, slot)
    }

    /// Makes `self` the particles of `source` in the order `order`: slot k of `self`
    /// receives slot `order[k]` of `source`. Density and acceleration start as stage 2
    /// sets them (0 and `gravity`), so the reordering also does that stage; every array
    /// is padded. `self`'s buffers are reused.
    pub fn gather_kinematics(&mut self, source: &Particles, order: &[u32], gravity: DVec3) {
        self.gather_for_pairs(source, order, gravity);
        gather_axes(&mut self.hv, &source.hv, order);
    }

    /// The positions of `source`'s slots `order`, in that order (padded); the other
    /// fields left as they were.
    pub fn gather_positions(&mut self, source: &Particles, order: &[u32]) {
        gather_axes(&mut self.p, &source.p, order);
    }

    /// As [`Self::gather_kinematics`] without the half-step velocities, which the pair
    /// passes do not read: a copy for them alone (its `hv` empty, so that no step can
    /// read one by mistake).
    pub fn gather_for_pairs(&mut self, source: &Particles, order: &[u32], gravity: DVec3) {
        self.id.clear();
        self.id.extend(order.iter().map(|&s| source.id[s as usize]));
        gather_axes(&mut self.p, &source.p, order);
        gather_axes(&mut self.v, &source.v, order);
        for axis in &mut self.hv {
            axis.clear();
        }
        self.reset_densities_and_accelerations(gravity);
    }

    /// As [`Self::gather_kinematics`], the densities carried over too (for a model whose
    /// density is a state of its own).
    pub fn gather_with_densities(&mut self, source: &Particles, order: &[u32], gravity: DVec3) {
        self.gather_kinematics(source, order, gravity);
        for (t, &k) in self.rho.iter_mut().zip(order) {
            *t = source.rho[k as usize];
        }
    }

    /// The particles in the order `order` (slot k holds slot `order[k]` of `self`), every
    /// field kept and every array padded (with zeros).
    pub fn permuted(&self, order: &[u32]) -> Particles {
        let mut out = Particles::default();
        out.gather_kinematics(self, order, DVec3::ZERO);
        for (target, source) in out
            .a
            .iter_mut()
            .chain([&mut out.rho])
            .zip(self.a.iter().chain([&self.rho]))
        {
            for (t, &k) in target.iter_mut().zip(order) {
                *t = source[k as usize];
            }
        }
        out
    }

    /// Stage 2: density 0 and acceleration = `gravity` for every particle (and padding).
    pub fn reset_densities_and_accelerations(&mut self, gravity: DVec3) {
        let n = self.len() + PADDING;
        self.rho.clear();
        self.rho.resize(n, 0.0);
        self.reset_accelerations(gravity);
    }

    /// Acceleration = `gravity` for every particle (and padding), densities kept.
    pub fn reset_accelerations(&mut self, gravity: DVec3) {
        let n = self.len() + PADDING;
        for (axis, g) in self.a.iter_mut().zip(gravity.to_array()) {
            axis.clear();
            axis.resize(n, g);
        }
    }

    /// A copy without the padding: every array exactly one element per particle.
    pub fn unpadded(&self) -> Particles {
        let n = self.len();
        let cut = |arrays: &AxisArrays| std::array::from_fn(|axis| arrays[axis][..n].to_vec());
        Particles {
            id: self.id.clone(),
            p: cut(&self.p),
            hv: cut(&self.hv),
            v: cut(&self.v),
            rho: self.rho[..n].to_vec(),
            a: cut(&self.a),
        }
    }

    /// Gives every `f64` array exactly [`PADDING`] elements after the last particle (zeros
    /// where added).
    pub fn pad(&mut self) {
        let n = self.len() + PADDING;
        let arrays = [&mut self.p, &mut self.hv, &mut self.v, &mut self.a]
            .into_iter()
            .flatten()
            .chain([&mut self.rho]);
        for array in arrays {
            array.resize(n, 0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::GRAVITY;

    #[test]
    fn gather_reorders_ids_and_kinematics() {
        let mut source = Particles::zeroed(3);
        for slot in 0..3 {
            source.p[0][slot] = slot as f64;
            source.hv[1][slot] = 10.0 + slot as f64;
            source.v[2][slot] = 20.0 + slot as f64;
        }
        let mut target = Particles::default();
        target.gather_kinematics(&source, &[2, 0, 1], GRAVITY);
        assert_eq!(target.id, vec![2, 0, 1]);
        assert_eq!(target.p[0][..3], [2.0, 0.0, 1.0]);
        assert_eq!(target.hv[1][..3], [12.0, 10.0, 11.0]);
        assert_eq!(target.v[2][..3], [22.0, 20.0, 21.0]);
        assert_eq!(target.position(0), DVec3::new(2.0, 0.0, 0.0));
        assert_eq!(target.rho, [0.0; 3 + PADDING]);
        assert_eq!(target.acceleration(2), GRAVITY);
        assert_eq!(target.p[0].len(), 3 + PADDING);
    }

    #[test]
    fn a_copy_for_the_pair_passes_has_no_half_step_velocities() {
        let mut source = Particles::zeroed(3);
        for slot in 0..3 {
            source.p[1][slot] = slot as f64;
            source.hv[0][slot] = 10.0 + slot as f64;
            source.v[0][slot] = 20.0 + slot as f64;
        }
        let mut target = Particles::default();
        target.gather_kinematics(&source, &[0, 1, 2], GRAVITY);
        target.gather_for_pairs(&source, &[1, 2], GRAVITY);
        assert_eq!(target.id, vec![1, 2]);
        assert_eq!(target.p[1][..2], [1.0, 2.0]);
        assert_eq!(target.v[0][..2], [21.0, 22.0]);
        assert!(target.hv.iter().all(Vec::is_empty));
        assert_eq!(target.rho, [0.0; 2 + PADDING]);
        assert_eq!(target.acceleration(1), GRAVITY);
    }

    #[test]
    fn densities_can_be_carried_over_and_kept() {
        let mut source = Particles::zeroed(3);
        source.rho = vec![1.0, 2.0, 3.0];
        let mut target = Particles::default();
        target.gather_with_densities(&source, &[2, 0, 1], GRAVITY);
        assert_eq!(target.rho[..3], [3.0, 1.0, 2.0]);
        assert_eq!(target.rho.len(), 3 + PADDING);
        target.a[0][1] = 5.0;
        target.reset_accelerations(GRAVITY);
        assert_eq!(target.rho[..3], [3.0, 1.0, 2.0]);
        assert_eq!(target.acceleration(1), GRAVITY);
    }

    #[test]
    fn pad_adds_zeros_after_the_last_particle_only_once() {
        let mut particles = Particles::zeroed(2);
        particles.v[1][1] = 4.0;
        particles.pad();
        particles.pad();
        assert_eq!(particles.v[1][..4], [0.0, 4.0, 0.0, 0.0]);
        assert_eq!(particles.v[1].len(), 2 + PADDING);
        assert_eq!(particles.rho.len(), 2 + PADDING);
        assert_eq!(particles.len(), 2);
    }

    #[test]
    fn reset_sets_zero_density_and_gravity() {
        let mut particles = Particles::zeroed(2);
        particles.rho[1] = 5.0;
        particles.a[1][0] = 3.0;
        particles.reset_densities_and_accelerations(GRAVITY);
        assert!(particles.rho.iter().all(|&rho| rho == 0.0));
        assert_eq!(particles.acceleration(1), GRAVITY);
    }
}
