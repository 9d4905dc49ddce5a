//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod manufactured;
pub mod restart;
pub mod shipped_mesh;
pub mod vtu;

use nalgebra::Vector3;

/// A small deterministic xorshift generator, so tests need no extra crate and are reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    pub fn vector(&mut self, lo: f64, hi: f64) -> Vector3<f64> {
        Vector3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// A positively oriented random tet of reasonable quality (a jittered regular-ish corner tet).
pub fn random_tet(rng: &mut Rng) -> [Vector3<f64>; 4] {
    loop {
        let origin = rng.vector(-2.0, 2.0);
        let x = [
            origin,
            origin + Vector3::new(1.0, 0.0, 0.0) + rng.vector(-0.3, 0.3),
            origin + Vector3::new(0.0, 1.0, 0.0) + rng.vector(-0.3, 0.3),
            origin + Vector3::new(0.0, 0.0, 1.0) + rng.vector(-0.3, 0.3),
        ];
        if tetfem::fe::element::shape_quality(&x) > 0.2
            && tetfem::fe::element::signed_volume(&x) > 0.0
        {
            return x;
        }
    }
}

/// The parts of a `.vtu` file the tests check, read with a real XML parser.
#[derive(Debug, Default)]
pub struct VtuSummary {
    pub points: usize,
    pub cells: usize,
    /// (section, name, components, values) of every named DataArray.
    pub arrays: Vec<(String, String, usize, Vec<f64>)>,
}

impl VtuSummary {
    pub fn array(&self, name: &str) -> Option<&(String, String, usize, Vec<f64>)> {
        self.arrays.iter().find(|a| a.1 == name)
    }
}

/// Parses a `.vtu` file's bytes, ASCII or appended binary ([`vtu::parse_vtu`]).
pub fn parse_vtu(bytes: impl AsRef<[u8]>) -> VtuSummary {
    let vtu = vtu::parse_vtu(bytes.as_ref());
    VtuSummary {
        points: vtu.points,
        cells: vtu.cells,
        arrays: vtu
            .arrays
            .into_iter()
            .map(|a| (a.section, a.name, a.components, a.values))
            .collect(),
    }
}
