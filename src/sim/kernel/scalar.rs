//! The reference pair loops: one pair at a time, in plain f64, each pair's terms added to
//! both particles at once.

use super::{Accelerations, Densities};
use crate::sim::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::sim::particles::vector_at;
use glam::DVec3;

/// Stage 3, one pair at a time.
pub(super) fn increment_densities(pass: Densities) {
    let Densities {
        params,
        tiles,
        p,
        rho,
        close,
        ..
    } = pass;
    let hits = &mut close.tiles;
    let h2 = params.h2;
    for tile in tiles {
        let mut hit = false;
        for i in tile.firsts() {
            for j in tile.partners(i) {
                let r2 = (vector_at(p, i) - vector_at(p, j)).length_squared();
                if r2 < h2 {
                    let q = h2 - r2;
                    let t = q * q * q;
                    rho[i] += t;
                    rho[j] += t;
                    hit = true;
                }
            }
        }
        if hit {
            hits.push(*tile);
        }
    }
}

/// The acceleration particle i gets from particle j (j gets its opposite, exactly), for a
/// pair closer than h with `offset` = p_i - p_j and `r2` = |offset|^2. `FLUIDANIMATE`
/// multiplies the viscosity term by (h - dist).
#[inline(always)]
pub(super) fn pair_acceleration<const FLUIDANIMATE: bool>(
    params: &Params,
    offset: DVec3,
    r2: f64,
    [v_i, v_j]: [DVec3; 2],
    [rho_i, rho_j]: [f64; 2],
) -> DVec3 {
    let dist = r2.max(MIN_DISTANCE_SQUARED).sqrt();
    let q = params.h - dist;
    let pressure = params.pressure_factor * q * q / dist * (rho_i + rho_j - 2.0 * FLUID_DENSITY);
    let mut viscosity = (v_j - v_i) * params.viscosity_factor;
    if FLUIDANIMATE {
        viscosity *= q;
    }
    (offset * pressure + viscosity) / (rho_i * rho_j)
}

/// Stage 5, one pair at a time.
pub(super) fn transfer_accelerations<const FLUIDANIMATE: bool>(pass: Accelerations<FLUIDANIMATE>) {
    let Accelerations {
        params,
        candidates,
        p,
        v,
        rho,
        a,
        ..
    } = pass;
    for tile in candidates.tiles() {
        for i in tile.firsts() {
            for j in tile.partners(i) {
                let offset = vector_at(p, i) - vector_at(p, j);
                let r2 = offset.length_squared();
                if r2 < params.h2 {
                    let velocities = [vector_at(v, i), vector_at(v, j)];
                    let da = pair_acceleration::<FLUIDANIMATE>(
                        params,
                        offset,
                        r2,
                        velocities,
                        [rho[i], rho[j]],
                    );
                    for (axis, da) in a.iter_mut().zip(da.to_array()) {
                        axis[i] += da;
                        axis[j] -= da;
                    }
                }
            }
        }
    }
}
