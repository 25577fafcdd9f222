//! Particle state as a structure of arrays: one contiguous `Vec` per field and axis, so the
//! physics loops stream through memory and can be vectorised.

use glam::DVec3;

/// Three arrays, one per axis, of one vector field.
pub type AxisArrays = [Vec<f64>; 3];

/// The state of every particle, stored slot by slot (in block order during a simulation).
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

impl Particles {
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
    /// receives slot `order[k]` of `source`. Density and acceleration are not carried
    /// over (the next stage resets them); `self`'s buffers are reused.
    pub fn gather_kinematics(&mut self, source: &Particles, order: &[u32]) {
        let n = order.len();
        self.id.clear();
        self.id.extend(order.iter().map(|&s| source.id[s as usize]));
        let fields = [
            (&mut self.p, &source.p),
            (&mut self.hv, &source.hv),
            (&mut self.v, &source.v),
        ];
        for (target, source) in fields {
            for (t, s) in target.iter_mut().zip(source) {
                t.clear();
                t.extend(order.iter().map(|&k| s[k as usize]));
            }
        }
        self.rho.resize(n, 0.0);
        for axis in &mut self.a {
            axis.resize(n, 0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_reorders_ids_and_kinematics() {
        let mut source = Particles::zeroed(3);
        for slot in 0..3 {
            source.p[0][slot] = slot as f64;
            source.hv[1][slot] = 10.0 + slot as f64;
            source.v[2][slot] = 20.0 + slot as f64;
        }
        let mut target = Particles::default();
        target.gather_kinematics(&source, &[2, 0, 1]);
        assert_eq!(target.id, vec![2, 0, 1]);
        assert_eq!(target.p[0], vec![2.0, 0.0, 1.0]);
        assert_eq!(target.hv[1], vec![12.0, 10.0, 11.0]);
        assert_eq!(target.v[2], vec![22.0, 20.0, 21.0]);
        assert_eq!(target.position(0), DVec3::new(2.0, 0.0, 0.0));
        assert_eq!(target.rho.len(), 3);
        assert_eq!(target.a[2].len(), 3);
    }
}
