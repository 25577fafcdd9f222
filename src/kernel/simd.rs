//! The vectorised pair loops: for each particle of a tile, its partners four at a time in
//! `f64x4` lanes. A lane counts only if it holds a partner (tail mask) closer than h
//! (cut-off mask); other lanes add exactly +0. The particle's own sums stay in registers
//! and are added once per tile; the partners' sums are updated lane-wise in memory.
//!
//! Loads of the last, partial group of four read up to three slots past the range: the
//! particle arrays carry [`PADDING`] extra elements so those reads stay in bounds, and the
//! masked lanes write back exactly what they read.

use crate::neighbours::Tile;
use crate::params::{Params, FLUID_DENSITY, MIN_DISTANCE_SQUARED};
use crate::particles::{AxisArrays, PADDING};
use wide::f64x4;

const LANES: usize = 4;

#[inline(always)]
fn load(values: &[f64], at: usize) -> f64x4 {
    let lanes: [f64; LANES] = values[at..at + LANES].try_into().unwrap();
    f64x4::from(lanes)
}

#[inline(always)]
fn add_to(values: &mut [f64], at: usize, lanes: f64x4) {
    let sum = load(values, at) + lanes;
    values[at..at + LANES].copy_from_slice(sum.as_array());
}

#[inline(always)]
fn subtract_from(values: &mut [f64], at: usize, lanes: f64x4) {
    let difference = load(values, at) - lanes;
    values[at..at + LANES].copy_from_slice(difference.as_array());
}

/// A mask of the first `count` lanes (all four for `count >= 4`).
#[inline(always)]
fn first_lanes(count: usize) -> f64x4 {
    f64x4::new([0.0, 1.0, 2.0, 3.0]).simd_lt(f64x4::splat(count as f64))
}

/// Panics unless every array leaves room for four-lane loads at the last slot `n - 1`.
fn assert_padded(n: usize, arrays: &[&[f64]]) {
    assert!(
        arrays.iter().all(|a| a.len() >= n + PADDING),
        "particle arrays must be padded by {PADDING} elements for the SIMD kernel"
    );
}

fn slots_used(tiles: &[Tile]) -> usize {
    tiles
        .iter()
        .map(|t| t.second_end as usize)
        .max()
        .unwrap_or(0)
}

pub(super) fn increment_densities(
    params: &Params,
    tiles: &[Tile],
    p: &AxisArrays,
    rho: &mut [f64],
    hits: &mut Vec<Tile>,
) {
    let [x, y, z] = p;
    assert_padded(slots_used(tiles), &[x, y, z, rho]);
    let h2 = f64x4::splat(params.h2);
    for tile in tiles {
        let mut any_close = f64x4::ZERO;
        for i in tile.firsts() {
            let (xi, yi, zi) = (f64x4::splat(x[i]), f64x4::splat(y[i]), f64x4::splat(z[i]));
            let mut sum = f64x4::ZERO;
            let partners = tile.partners(i);
            let mut j = partners.start;
            while j < partners.end {
                let (dx, dy, dz) = (xi - load(x, j), yi - load(y, j), zi - load(z, j));
                let r2 = dx * dx + dy * dy + dz * dz;
                let close = r2.simd_lt(h2) & first_lanes(partners.end - j);
                let q = h2 - r2;
                let t = (q * q * q) & close;
                sum += t;
                add_to(rho, j, t);
                any_close |= close;
                j += LANES;
            }
            rho[i] += sum.reduce_add();
        }
        if any_close.any() {
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
    let ([x, y, z], [vx, vy, vz]) = (p, v);
    let [ax, ay, az] = a;
    assert_padded(slots_used(tiles), &[x, y, z, vx, vy, vz, rho, ax, ay, az]);
    let h = f64x4::splat(params.h);
    let h2 = f64x4::splat(params.h2);
    let min_distance_squared = f64x4::splat(MIN_DISTANCE_SQUARED);
    let pressure_factor = f64x4::splat(params.pressure_factor);
    let viscosity_factor = f64x4::splat(params.viscosity_factor);
    let twice_rest_density = f64x4::splat(2.0 * FLUID_DENSITY);
    for tile in tiles {
        for i in tile.firsts() {
            let (xi, yi, zi) = (f64x4::splat(x[i]), f64x4::splat(y[i]), f64x4::splat(z[i]));
            let (vxi, vyi, vzi) = (
                f64x4::splat(vx[i]),
                f64x4::splat(vy[i]),
                f64x4::splat(vz[i]),
            );
            let rho_i = f64x4::splat(rho[i]);
            let (mut sx, mut sy, mut sz) = (f64x4::ZERO, f64x4::ZERO, f64x4::ZERO);
            let partners = tile.partners(i);
            let mut j = partners.start;
            while j < partners.end {
                let (dx, dy, dz) = (xi - load(x, j), yi - load(y, j), zi - load(z, j));
                let r2 = dx * dx + dy * dy + dz * dz;
                let close = r2.simd_lt(h2) & first_lanes(partners.end - j);
                if close.any() {
                    let dist = r2.max(min_distance_squared).sqrt();
                    let q = h - dist;
                    let rho_j = load(rho, j);
                    let pressure =
                        pressure_factor * q * q / dist * (rho_i + rho_j - twice_rest_density);
                    let viscosity = |vj: f64x4, vi: f64x4| {
                        let term = (vj - vi) * viscosity_factor;
                        if FLUIDANIMATE {
                            term * q
                        } else {
                            term
                        }
                    };
                    let density_product = rho_i * rho_j;
                    let dax =
                        ((dx * pressure + viscosity(load(vx, j), vxi)) / density_product) & close;
                    let day =
                        ((dy * pressure + viscosity(load(vy, j), vyi)) / density_product) & close;
                    let daz =
                        ((dz * pressure + viscosity(load(vz, j), vzi)) / density_product) & close;
                    sx += dax;
                    sy += day;
                    sz += daz;
                    subtract_from(ax, j, dax);
                    subtract_from(ay, j, day);
                    subtract_from(az, j, daz);
                }
                j += LANES;
            }
            ax[i] += sx.reduce_add();
            ay[i] += sy.reduce_add();
            az[i] += sz.reduce_add();
        }
    }
}
