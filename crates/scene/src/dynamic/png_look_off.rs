//! The dynamic frames' stand-in without the `png` feature (see `png_look.rs`): each an error,
//! reached only through a caller's `force_png`, before the first step.

// The stand-ins keep the real module's fields so that its callers compile unchanged; nothing
// reads them here.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use super::DynamicSetup;
use crate::png_frames::no_png;
use crate::{OutputSettings, SceneElement};
use tetfem::base::error::Result;

/// The frames' look (none without the feature).
pub(crate) struct PngLook;

/// One dynamic frame to draw (see `png_frames.rs`).
pub(crate) struct PngFrame<'a> {
    pub time: f64,
    pub step: usize,
    pub title: &'a str,
    pub size: [u32; 2],
    pub path: &'a Path,
}

impl PngLook {
    /// Refuses: no PNG frames in this build.
    pub(crate) fn draw<E: SceneElement>(
        &mut self,
        _setup: &DynamicSetup<E>,
        _u: &[f64],
        _frame: &PngFrame,
    ) -> Result<PathBuf> {
        Err(no_png())
    }
}

/// Refuses: no PNG frames in this build.
pub(crate) fn dynamic_look<E: SceneElement>(
    _setup: &DynamicSetup<E>,
    _s: &OutputSettings,
    _frame_times: &[f64],
) -> Result<PngLook> {
    Err(no_png())
}
