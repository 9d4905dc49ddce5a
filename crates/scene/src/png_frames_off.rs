//! The static picture's stand-in without the `png` feature: the same names as `png_frames.rs`,
//! each an error. A scene with `output.png = true` is refused when it is read, so only a
//! caller's `force_png` reaches it (`dynamic/png_look_off.rs` is the dynamic frames' one).

// The stand-ins keep the real module's fields so that its callers compile unchanged; nothing
// reads them here.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use crate::Scene;
use tetfem::base::error::{Error, Result};
use tetfem::mesh::{CellType, TetMesh};

pub(crate) fn no_png() -> Error {
    Error::Scene {
        source_name: "<options>".into(),
        key: "output.png".into(),
        line: 0,
        message: "this build of tetfem-scene has no PNG frames (its `png` feature is off)".into(),
    }
}

/// What the static picture shows (see `png_frames.rs`).
pub(crate) struct StaticLook<'a> {
    pub title: &'a str,
    pub magnitude: &'a [f64],
    pub von_mises: &'a [f64],
    pub path: &'a Path,
}

/// Refuses: no PNG frames in this build.
pub(crate) fn static_picture<C: CellType>(
    _scene: &Scene,
    _mesh: &TetMesh<C>,
    _u: &[f64],
    _look: &StaticLook,
) -> Result<PathBuf> {
    Err(no_png())
}
