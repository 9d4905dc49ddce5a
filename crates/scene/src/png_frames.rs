//! The static scene's PNG picture (feature `png`), and the magnification's format every frame's
//! subtitle prints. A dynamic run's frames are `dynamic::png_look`.

use std::path::{Path, PathBuf};

use crate::render::{Field, ObstacleView, RenderOptions, auto_deformation_scale, render};
use crate::{PngField, Scene};
use tetfem::base::error::Result;
use tetfem::mesh::{CellType, TetMesh};

/// A magnification as the frames' subtitles print it: whole above 100, else up to three
/// decimals without trailing zeros.
pub(crate) fn format_scale(scale: f64) -> String {
    if scale >= 100.0 {
        format!("{scale:.0}")
    } else {
        format!("{scale:.3}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

/// What the static picture shows: its title, the nodes' |u| (m), the cells' von Mises stress
/// (Pa), and the file it goes to.
pub(crate) struct StaticLook<'a> {
    pub title: &'a str,
    pub magnitude: &'a [f64],
    pub von_mises: &'a [f64],
    pub path: &'a Path,
}

/// The static scene's picture of displacement `u` (m, every DOF) on `mesh`: magnified by
/// `output.deformation_scale` or the automatic rule (true to scale with obstacles), coloured
/// by `output.png_field`; returns the file written.
pub(crate) fn static_picture<C: CellType>(
    scene: &Scene,
    mesh: &TetMesh<C>,
    u: &[f64],
    look: &StaticLook,
) -> Result<PathBuf> {
    let out = &scene.output;
    // With obstacles the body is drawn true to scale: magnified, it would seem to pass
    // into the obstacles it touches.
    let scale = if out.deformation_scale > 0.0 {
        out.deformation_scale
    } else if scene.has_obstacles() {
        1.0
    } else {
        auto_deformation_scale(mesh, u)
    };
    let field = match out.png_field {
        PngField::Displacement => Field::Nodes {
            name: "|u| (m)",
            values: look.magnitude,
        },
        PngField::VonMises => Field::Cells {
            name: "von Mises (Pa)",
            values: look.von_mises,
        },
    };
    let image = render(
        mesh,
        u,
        &field,
        &RenderOptions {
            width: out.png_size[0],
            height: out.png_size[1],
            title: look.title.to_string(),
            subtitle: format!("static, deformation ×{}", format_scale(scale)),
            deformation_scale: scale,
            // Where the solution has them: a moving obstacle at the end of the static
            // step's pseudo-time, t = 1 (a fixed one anywhere).
            obstacles: scene
                .obstacles
                .iter()
                .map(|o| ObstacleView::at(o, tetfem::bc::amplitude::STATIC_TIME))
                .collect(),
            ..RenderOptions::default()
        },
    )?;
    image.write_png(look.path)?;
    Ok(look.path.to_path_buf())
}
