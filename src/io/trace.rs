//! Reader for the course's per-stage trace files (`.trz`, SPEC.md section 6): the full
//! double-precision state after one stage, block by block.

use crate::sim::particles::Particles;
use std::io;
use std::path::Path;

/// Bytes per particle in a trace: i64 id and 13 f64.
const PARTICLE_BYTES: usize = 8 + 13 * 8;

/// The state recorded in a trace: particles in cell order and the count of each block.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Particles per block, in linear block order.
    pub block_counts: Vec<u32>,
    /// Every particle, block after block, in the order the trace lists them.
    pub particles: Particles,
}

impl Trace {
    /// Reads and decodes a trace file.
    pub fn read(path: &Path) -> io::Result<Self> {
        Self::parse(&std::fs::read(path)?)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))
    }

    /// Decodes the bytes of a trace, checking that they are exactly one well-formed trace.
    pub fn parse(bytes: &[u8]) -> io::Result<Self> {
        let mut reader = Reader { bytes, at: 0 };
        let blocks = usize::try_from(reader.i32()?).map_err(|_| invalid("negative block count"))?;
        let mut block_counts = Vec::with_capacity(blocks.min(bytes.len() / 8));
        let mut particles = Particles::default();
        for _ in 0..blocks {
            let count = u32::try_from(reader.i64()?).map_err(|_| invalid("bad block size"))?;
            if reader.remaining() < count as usize * PARTICLE_BYTES {
                return Err(invalid("truncated block"));
            }
            block_counts.push(count);
            for _ in 0..count {
                let id = u32::try_from(reader.i64()?).map_err(|_| invalid("bad particle id"))?;
                particles.id.push(id);
                for axis in 0..3 {
                    particles.p[axis].push(reader.f64()?);
                }
                for axis in 0..3 {
                    particles.hv[axis].push(reader.f64()?);
                }
                for axis in 0..3 {
                    particles.v[axis].push(reader.f64()?);
                }
                particles.rho.push(reader.f64()?);
                for axis in 0..3 {
                    particles.a[axis].push(reader.f64()?);
                }
            }
        }
        if reader.remaining() != 0 {
            return Err(invalid("trailing bytes"));
        }
        Ok(Self {
            block_counts,
            particles,
        })
    }

    /// The block of each particle, in the trace's order.
    pub fn blocks(&self) -> Vec<u32> {
        let blocks = self.block_counts.iter().enumerate();
        blocks
            .flat_map(|(block, &count)| std::iter::repeat_n(block as u32, count as usize))
            .collect()
    }
}

fn invalid(what: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, format!("invalid trace: {what}"))
}

/// A little-endian cursor over the trace bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> io::Result<[u8; N]> {
        let chunk = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or_else(|| invalid("truncated"))?;
        self.at += N;
        Ok(chunk.try_into().expect("N bytes"))
    }

    fn i32(&mut self) -> io::Result<i32> {
        self.take().map(i32::from_le_bytes)
    }

    fn i64(&mut self) -> io::Result<i64> {
        self.take().map(i64::from_le_bytes)
    }

    fn f64(&mut self) -> io::Result<f64> {
        self.take().map(f64::from_le_bytes)
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace_bytes(blocks: &[&[(i64, f64)]]) -> Vec<u8> {
        let mut bytes = (blocks.len() as i32).to_le_bytes().to_vec();
        for block in blocks {
            bytes.extend((block.len() as i64).to_le_bytes());
            for &(id, base) in *block {
                bytes.extend(id.to_le_bytes());
                for field in 0..13 {
                    bytes.extend((base + field as f64).to_le_bytes());
                }
            }
        }
        bytes
    }

    #[test]
    fn parses_blocks_and_fields_in_order() {
        let trace =
            Trace::parse(&trace_bytes(&[&[(4, 0.0)], &[], &[(1, 100.0), (0, 200.0)]])).unwrap();
        assert_eq!(trace.block_counts, vec![1, 0, 2]);
        let p = &trace.particles;
        assert_eq!(p.id, vec![4, 1, 0]);
        assert_eq!(p.p[2], vec![2.0, 102.0, 202.0]);
        assert_eq!(p.hv[0], vec![3.0, 103.0, 203.0]);
        assert_eq!(p.v[1], vec![7.0, 107.0, 207.0]);
        assert_eq!(p.rho, vec![9.0, 109.0, 209.0]);
        assert_eq!(p.a[2], vec![12.0, 112.0, 212.0]);
        assert_eq!(trace.blocks(), [0, 2, 2]);
    }

    #[test]
    fn rejects_truncated_and_padded_traces() {
        let bytes = trace_bytes(&[&[(0, 1.0)]]);
        assert!(Trace::parse(&bytes[..bytes.len() - 1]).is_err());
        let mut padded = bytes.clone();
        padded.push(0);
        assert!(Trace::parse(&padded).is_err());
        assert!(Trace::parse(&(-1i32).to_le_bytes()).is_err());
        assert!(Trace::parse(&[]).is_err());
    }
}
