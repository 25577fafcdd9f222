//! The reference pair loops: one pair at a time, in plain f64, each pair's terms added to
//! both particles at once.

use crate::neighbours::Tile;
use crate::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::particles::{vector_at, AxisArrays};

pub(super) fn increment_densities(
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    rho: &mut [f64],
    hits: &mut Vec<Tile>,
) {
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

/// `FLUIDANIMATE` multiplies the viscosity term by (h - dist).
pub(super) fn transfer_accelerations<const FLUIDANIMATE: bool>(
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    v: &AxisArrays,
    rho: &[f64],
    a: &mut AxisArrays,
) {
    let Params {
        h,
        h2,
        pressure_factor,
        viscosity_factor,
        ..
    } = *params;
    for tile in tiles {
        for i in tile.firsts() {
            for j in tile.partners(i) {
                let offset = vector_at(p, i) - vector_at(p, j);
                let r2 = offset.length_squared();
                if r2 < h2 {
                    let dist = r2.max(MIN_DISTANCE_SQUARED).sqrt();
                    let q = h - dist;
                    let pressure =
                        pressure_factor * q * q / dist * (rho[i] + rho[j] - 2.0 * FLUID_DENSITY);
                    let mut viscosity = (vector_at(v, j) - vector_at(v, i)) * viscosity_factor;
                    if FLUIDANIMATE {
                        viscosity *= q;
                    }
                    let da = (offset * pressure + viscosity) / (rho[i] * rho[j]);
                    for (axis, da) in a.iter_mut().zip(da.to_array()) {
                        axis[i] += da;
                        axis[j] -= da;
                    }
                }
            }
        }
    }
}
