//! A state as per-particle records in file order, with the density the model gives it and
//! the block stage 1 puts it in, written as legacy VTK (which ParaView opens: positions as
//! points; velocity, half velocity, density, block and id as point data) or as CSV.

use crate::sim::cells::cell_of;
use crate::sim::params::Domain;
use crate::sim::particles::vector_at;
use crate::sim::simulation::Simulation;
use glam::DVec3;
use std::fmt::Write;

/// One state of a simulation, particle by particle in file (id) order.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The time step this state follows (0 for the input).
    pub step: u64,
    /// The physical time of this state (s).
    pub time: f64,
    /// Positions.
    pub position: Vec<DVec3>,
    /// Half-step velocities.
    pub half_velocity: Vec<DVec3>,
    /// Velocities.
    pub velocity: Vec<DVec3>,
    /// Densities at these positions (stages 1, 3 and 4 of the next step).
    pub density: Vec<f64>,
    /// The linear index of each particle's block (its cell clamped into the grid).
    pub block: Vec<u32>,
    /// The box and gravity of the simulation.
    pub domain: Domain,
}

impl Snapshot {
    /// The state of `simulation` after `step` steps. Densities are computed afresh for the
    /// current positions, on a copy, so the simulation itself is not disturbed.
    pub fn of(simulation: &Simulation, step: u64) -> Snapshot {
        let copy = simulation.with_fresh_densities();
        let particles = copy.particles();
        let grid = copy.grid();
        let n = particles.len();
        let mut snapshot = Snapshot {
            step,
            time: simulation.time(),
            position: vec![DVec3::ZERO; n],
            half_velocity: vec![DVec3::ZERO; n],
            velocity: vec![DVec3::ZERO; n],
            density: vec![0.0; n],
            block: vec![0; n],
            domain: simulation.params().domain,
        };
        for slot in 0..n {
            let id = particles.id[slot] as usize;
            let position = vector_at(&particles.p, slot);
            snapshot.position[id] = position;
            snapshot.half_velocity[id] = vector_at(&particles.hv, slot);
            snapshot.velocity[id] = vector_at(&particles.v, slot);
            snapshot.density[id] = particles.rho[slot];
            let cell = cell_of(grid, position.to_array());
            let coords: [usize; 3] =
                std::array::from_fn(|d| cell[d].clamp(0, grid.dims[d] as i32 - 1) as usize);
            snapshot.block[id] = grid.index(coords) as u32;
        }
        snapshot
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// The state as a legacy ASCII VTK polydata file titled `title`: one vertex per
    /// particle; file values (positions, velocities) as float, exactly as in the `.fld`;
    /// densities as double.
    pub fn to_vtk(&self, title: &str) -> String {
        let n = self.len();
        let mut text = String::with_capacity(n * 160);
        let title: String = title.chars().filter(|c| *c != '\n').take(250).collect();
        let _ = write!(
            text,
            "# vtk DataFile Version 3.0\n{title}\nASCII\nDATASET POLYDATA\nPOINTS {n} float\n"
        );
        write_vectors(&mut text, &self.position);
        let _ = writeln!(text, "VERTICES {n} {}", 2 * n);
        for i in 0..n {
            let _ = writeln!(text, "1 {i}");
        }
        let _ = writeln!(text, "POINT_DATA {n}");
        let _ = writeln!(text, "VECTORS velocity float");
        write_vectors(&mut text, &self.velocity);
        let _ = writeln!(text, "VECTORS half_velocity float");
        write_vectors(&mut text, &self.half_velocity);
        let _ = writeln!(text, "SCALARS density double 1\nLOOKUP_TABLE default");
        for density in &self.density {
            let _ = writeln!(text, "{density}");
        }
        let _ = writeln!(text, "SCALARS block int 1\nLOOKUP_TABLE default");
        for block in &self.block {
            let _ = writeln!(text, "{block}");
        }
        let _ = writeln!(text, "SCALARS id int 1\nLOOKUP_TABLE default");
        for id in 0..n {
            let _ = writeln!(text, "{id}");
        }
        text
    }

    /// The state as CSV: `id,px,py,pz,hvx,hvy,hvz,vx,vy,vz,density,block`.
    pub fn to_csv(&self) -> String {
        let mut text = String::with_capacity(self.len() * 160);
        text.push_str("id,px,py,pz,hvx,hvy,hvz,vx,vy,vz,density,block\n");
        for id in 0..self.len() {
            let _ = write!(text, "{id}");
            for vector in [self.position[id], self.half_velocity[id], self.velocity[id]] {
                for value in vector.to_array() {
                    let _ = write!(text, ",{}", value as f32);
                }
            }
            let _ = writeln!(text, ",{},{}", self.density[id], self.block[id]);
        }
        text
    }
}

/// A ParaView collection (`.pvd`) of `frames`: each file name (relative to the
/// collection) with the physical time (s) it shows, so ParaView plays the series in
/// simulated time.
pub fn pvd_collection(frames: &[(String, f64)]) -> String {
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" \
         byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (file, time) in frames {
        let file = xml_escaped(file);
        let _ = writeln!(
            text,
            "    <DataSet timestep=\"{time:e}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    text.push_str("  </Collection>\n</VTKFile>\n");
    text
}

/// The index of a series of frames exported without times of their own (CSV, legacy
/// VTK): a CSV of each frame's step, its physical time (s) and its file (relative to
/// the index), as the `.pvd` is for `.vtp` frames.
pub fn frames_index(frames: &[(u64, f64, String)]) -> String {
    let mut writer = csv::Writer::from_writer(Vec::new());
    let rows = std::iter::once(["step", "time_s", "file"].map(String::from)).chain(
        frames
            .iter()
            .map(|(step, time, file)| [step.to_string(), time.to_string(), file.clone()]),
    );
    for row in rows {
        writer.write_record(&row).expect("a CSV row in memory");
    }
    String::from_utf8(writer.into_inner().expect("CSV in memory")).expect("UTF-8 fields")
}

/// `text` with the characters XML reserves in attributes escaped.
fn xml_escaped(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

impl Snapshot {
    /// The state as a VTK XML PolyData file (`.vtp`) with its arrays appended as raw
    /// little-endian binary (UInt64 block sizes): points and velocities as Float32, exactly
    /// as in the `.fld`; density as Float64; block and id as Int32; one vertex per particle.
    pub fn to_vtp(&self) -> Vec<u8> {
        let n = self.len();
        let f32s = |vectors: &[DVec3]| -> Vec<u8> {
            vectors
                .iter()
                .flat_map(|v| v.to_array().map(|x| x as f32))
                .flat_map(f32::to_le_bytes)
                .collect()
        };
        let ids: Vec<u8> = (0..n as i32).flat_map(i32::to_le_bytes).collect();
        let arrays: [(&str, &str, usize, Vec<u8>); 8] = [
            ("Points", "Float32", 3, f32s(&self.position)),
            ("velocity", "Float32", 3, f32s(&self.velocity)),
            ("half_velocity", "Float32", 3, f32s(&self.half_velocity)),
            (
                "density",
                "Float64",
                1,
                self.density.iter().flat_map(|d| d.to_le_bytes()).collect(),
            ),
            (
                "block",
                "Int32",
                1,
                self.block
                    .iter()
                    .flat_map(|&b| (b as i32).to_le_bytes())
                    .collect(),
            ),
            ("id", "Int32", 1, ids),
            (
                "connectivity",
                "Int64",
                1,
                (0..n as i64).flat_map(i64::to_le_bytes).collect(),
            ),
            (
                "offsets",
                "Int64",
                1,
                (1..=n as i64).flat_map(i64::to_le_bytes).collect(),
            ),
        ];
        let mut offset = 0usize;
        let mut tags = Vec::new();
        for (name, kind, components, bytes) in &arrays {
            tags.push(format!(
                "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" \
                 format=\"appended\" offset=\"{offset}\"/>"
            ));
            offset += 8 + bytes.len();
        }
        // Points, then the point data, then the vertex lists.
        let text = format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<PolyData>\n\
             <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\">\n\
             <Points>{}</Points>\n<PointData>{}</PointData>\n\
             <Verts>{}</Verts>\n</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">\n_",
            tags[0],
            tags[1..6].concat(),
            tags[6..].concat()
        );
        let mut bytes = Vec::with_capacity(text.len() + offset + 64);
        bytes.extend_from_slice(text.as_bytes());
        for (_, _, _, data) in &arrays {
            bytes.extend_from_slice(&(data.len() as u64).to_le_bytes());
            bytes.extend_from_slice(data);
        }
        bytes.extend_from_slice(b"\n</AppendedData>\n</VTKFile>\n");
        bytes
    }
}

/// Writes vectors one per line as f32, the precision of `.fld` files.
fn write_vectors(text: &mut String, vectors: &[DVec3]) {
    for vector in vectors {
        let [x, y, z] = vector.to_array().map(|v| v as f32);
        let _ = writeln!(text, "{x} {y} {z}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::params::BOX_MIN;
    use crate::sim::particles::Particles;

    /// Two particles 1 mm apart near the low corner, and one far away, at ppm 200.
    fn simulation() -> Simulation {
        let mut particles = Particles::zeroed(3);
        let points = [
            BOX_MIN + 0.01,
            BOX_MIN + DVec3::new(0.011, 0.01, 0.01),
            DVec3::new(0.05, 0.09, 0.05),
        ];
        for (slot, point) in points.iter().enumerate() {
            for axis in 0..3 {
                particles.p[axis][slot] = point[axis];
                particles.v[axis][slot] = (slot * 3 + axis) as f64 * 0.25;
            }
        }
        Simulation::new(200.0, particles).unwrap()
    }

    #[test]
    fn a_snapshot_holds_file_order_densities_and_blocks() {
        let snapshot = Snapshot::of(&simulation(), 0);
        assert_eq!(snapshot.len(), 3);
        assert_eq!(snapshot.velocity[2], DVec3::new(1.5, 1.75, 2.0));
        // The lone particle's density is its own contribution only: the transform of a
        // zero sum; the pair's are larger and equal.
        // (The simulation's own parameters: `powi` of a constant may fold differently.)
        let params = *simulation().params();
        assert_eq!(snapshot.density[2], params.h6 * params.density_factor);
        assert!(snapshot.density[0] > snapshot.density[2]);
        assert_eq!(snapshot.density[0], snapshot.density[1]);
        // Block of the first particle: 1 cm from the corner, blocks about h wide.
        let grid = simulation().grid().to_owned();
        let expected = |p: DVec3| {
            let coords = ((p - BOX_MIN) / grid.block_size)
                .floor()
                .to_array()
                .map(|c| c as usize);
            grid.index(coords) as u32
        };
        assert_eq!(snapshot.block[0], expected(snapshot.position[0]));
        assert_eq!(snapshot.block[2], expected(snapshot.position[2]));
    }

    #[test]
    fn vtk_and_csv_hold_every_field() {
        let snapshot = Snapshot::of(&simulation(), 4);
        let vtk = snapshot.to_vtk("fluid test, step 4");
        let lines: Vec<&str> = vtk.lines().collect();
        assert_eq!(
            lines[..5],
            [
                "# vtk DataFile Version 3.0",
                "fluid test, step 4",
                "ASCII",
                "DATASET POLYDATA",
                "POINTS 3 float"
            ]
        );
        assert_eq!(lines[5], "-0.055 -0.07 -0.055");
        assert_eq!(
            lines[8..13],
            ["VERTICES 3 6", "1 0", "1 1", "1 2", "POINT_DATA 3"]
        );
        assert_eq!(lines[13], "VECTORS velocity float");
        assert_eq!(lines[16], "1.5 1.75 2");
        let csv = snapshot.to_csv();
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[0], "id,px,py,pz,hvx,hvy,hvz,vx,vy,vz,density,block");
        assert!(
            rows[3].starts_with("2,0.05,0.09,0.05,0,0,0,1.5,1.75,2,"),
            "{}",
            rows[3]
        );
        assert_eq!(rows.len(), 4);
    }
}
