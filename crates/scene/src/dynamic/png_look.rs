//! A dynamic run's PNG frames (feature `png`): their look (chosen before the run from what it
//! can foresee, widened by a frame that reaches beyond it) and each frame. The `.vtu`/`.pvd`/CSV
//! writers need none of it.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::DynamicSetup;
use crate::dynamic_contact::contact_of;
use crate::png_frames::format_scale;
use crate::render::{Field, ObstacleView, RenderOptions, render};
use crate::{OutputSettings, PngField, SceneElement};
use tetfem::base::error::Result;
use tetfem::contact::{Contact, Shape};
use tetfem::mesh::{CellType, TetMesh};
use tetfem::post::output::fields::displacement_magnitude;

/// The look of the PNG frames: set before the run from what the start state, the static shape
/// and the prescribed motion let foresee (see [`PngLook::new`]), held from frame to frame, and
/// widened only by a frame that reaches beyond it (see [`PngLook::fit`]).
pub(crate) struct PngLook {
    scale: f64,
    range: (f64, f64),
    field: PngField,
    /// The camera's box for a nonlinear model's frames (see [`PngLook::new`]).
    view_box: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Whether the magnification is chosen here (not set by `output.deformation_scale`, and a
    /// linear model's: a nonlinear one is drawn true to scale).
    auto_scale: bool,
    /// The largest |u| (m) the automatic magnification draws as a tenth of the body's size.
    scale_for: f64,
    /// The body's size: its bounding-box diagonal (m).
    size: f64,
}

/// How far above a frame's largest value a widened colour range (or magnification) reaches:
/// room for a swing that keeps growing, so that the look changes a few times, not every frame.
const LOOK_HEADROOM: f64 = 1.25;

impl PngLook {
    /// Widens the look for a frame whose largest |u| is `largest_u` (m) and whose largest
    /// drawn value is `largest_value` (the field's units): a value above the colour range
    /// raises its top to [`LOOK_HEADROOM`] × that value, and with an automatic magnification a
    /// |u| above the one it was chosen for lowers it to draw [`LOOK_HEADROOM`] × that |u| as a
    /// tenth of the body's size (the rule of [`crate::render::auto_deformation_scale`]). The look never
    /// narrows: every frame's colour bar covers that frame's values, and consecutive frames
    /// share one look until one reaches beyond it.
    fn fit(&mut self, largest_u: f64, largest_value: f64) {
        if largest_value.is_finite() && largest_value > self.range.1 {
            self.range.1 = LOOK_HEADROOM * largest_value;
        }
        if self.auto_scale && largest_u.is_finite() && largest_u > self.scale_for {
            self.scale_for = LOOK_HEADROOM * largest_u;
            self.scale = (0.1 * self.size / self.scale_for).max(1.0);
        }
    }
}

/// One dynamic frame to draw: its time (s), step, title, image size (pixels) and file.
pub(crate) struct PngFrame<'a> {
    pub time: f64,
    pub step: usize,
    pub title: &'a str,
    pub size: [u32; 2],
    pub path: &'a Path,
}

impl PngLook {
    /// Draws displacement `u` (m, every DOF) of `setup`'s body at `frame` into `frame.path`,
    /// widening the look first if this frame reaches beyond it ([`PngLook::fit`]); returns the
    /// file written.
    pub(crate) fn draw<E: SceneElement>(
        &mut self,
        setup: &DynamicSetup<E>,
        u: &[f64],
        frame: &PngFrame,
    ) -> Result<PathBuf> {
        let magnitude = displacement_magnitude(u);
        let stress;
        let field = match self.field {
            PngField::Displacement => Field::Nodes {
                name: "|u| (m)",
                values: &magnitude,
            },
            PngField::VonMises => {
                stress = setup.von_mises(u)?;
                Field::Cells {
                    name: "von Mises (Pa)",
                    values: &stress,
                }
            }
        };
        let largest = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let drawn = match &field {
            Field::Nodes { values, .. } | Field::Cells { values, .. } => largest(values),
        };
        self.fit(largest(&magnitude), drawn);
        let image = render(
            &setup.mesh,
            u,
            &field,
            &RenderOptions {
                width: frame.size[0],
                height: frame.size[1],
                title: frame.title.to_string(),
                subtitle: format!(
                    "t = {:.4e} s (step {}), deformation ×{}",
                    frame.time,
                    frame.step,
                    format_scale(self.scale)
                ),
                deformation_scale: self.scale,
                range: Some(self.range),
                view_box: self.view_box,
                obstacles: contact_of(&setup.force)
                    .map(|c| {
                        c.obstacles()
                            .iter()
                            .map(|o| ObstacleView::at(o, frame.time))
                            .collect()
                    })
                    .unwrap_or_default(),
                ..RenderOptions::default()
            },
        )?;
        image.write_png(frame.path)?;
        Ok(frame.path.to_path_buf())
    }
}

/// The most frame times [`PngLook::new`] samples the prescribed motion at (evenly spread over the
/// frames): a bound on its cost; a frame between them that moves further widens the look.
const LOOK_MOTION_SAMPLES: usize = 256;

/// The magnification and colour range the frames start with: from the largest of the initial
/// displacement, twice the static one (a suddenly applied load overshoots to about twice its
/// static deflection) and, with moving supports, the static one plus the supports' largest
/// prescribed displacement (sampled at up to [`LOOK_MOTION_SAMPLES`] of `frame_times`, s). A
/// frame that reaches beyond them widens them ([`PngLook::fit`]): e.g. a body on a shaken
/// base resonating above the base's amplitude.
pub(crate) fn dynamic_look<E: SceneElement>(
    setup: &DynamicSetup<E>,
    s: &OutputSettings,
    frame_times: &[f64],
) -> Result<PngLook> {
    let dofs = setup.system.dofs();
    let initial = dofs.expand(&setup.initial.displacement)?;
    let contact = contact_of(&setup.force);
    // A body held by contact alone (with obstacles or other bodies) has no static shape
    // without it (K_ff is singular).
    let held_by_contact = contact.is_some() || setup.bodies.is_some();
    let (statics, free_body) = match (setup.system.static_displacement(), held_by_contact) {
        (Err(_), true) => (vec![0.0; setup.system.free_count()], true),
        (u, _) => (u?, false),
    };
    let doubled: Vec<f64> = dofs.expand(&statics)?.iter().map(|u| 2.0 * u).collect();
    let largest = |u: &[f64]| displacement_magnitude(u).into_iter().fold(0.0, f64::max);
    let reference = if largest(&initial) >= largest(&doubled) {
        initial
    } else {
        doubled
    };
    // A body on moving supports follows them: it moves by about their displacement on top of
    // its static shape.
    let shaken = largest(&dofs.expand(&statics)?) + prescribed_peak(setup, frame_times)?;
    let nonlinear = setup.force.is_nonlinear();
    // A nonlinear model's displacements are drawn as they are (magnifying a large rotation
    // would tear the picture), and the linear static shape can be far beyond its swing: its
    // colour range is capped at the body's size (bounding-box diagonal), its stress range
    // taken from the model's stress at that capped shape.
    let size = body_size(&setup.mesh);
    let foreseen = largest(&reference).max(shaken);
    let scale = if s.deformation_scale > 0.0 {
        s.deformation_scale
    } else if nonlinear || foreseen <= 0.0 || !foreseen.is_finite() {
        1.0
    } else {
        // The rule of `auto_deformation_scale`, for the foreseen largest |u|.
        (0.1 * size / foreseen).max(1.0)
    };
    let reference = if nonlinear {
        let big = largest(&reference);
        let shrink = if big > size { size / big } else { 1.0 };
        reference.iter().map(|u| shrink * u).collect()
    } else {
        reference
    };
    let high = match (s.png_field, free_body) {
        (PngField::Displacement, false) if nonlinear => largest(&reference).max(shaken.min(size)),
        (PngField::Displacement, false) => foreseen,
        (PngField::VonMises, false) => setup.von_mises(&reference)?.into_iter().fold(0.0, f64::max),
        // Without a static shape: a tenth of the body's size, and twice the stress of its
        // weight W on a face-sized area (diagonal²/3; ρ·g·H for a cube resting on a face).
        (PngField::Displacement, true) => 0.1 * body_size(&setup.mesh),
        (PngField::VonMises, true) => {
            let g = setup.system.gravity_load();
            let weight = (0..3)
                .map(|a| g.iter().skip(a).step_by(3).sum::<f64>().powi(2))
                .sum::<f64>()
                .sqrt();
            2.0 * weight / (body_size(&setup.mesh).powi(2) / 3.0)
        }
    };
    // A nonlinear model's large motion would make every frame zoom onto its own shape: one
    // camera for all, framing the body at rest and at the capped reference shape.
    let view_box = nonlinear.then(|| {
        let mut low = Vector3::repeat(f64::INFINITY);
        let mut high = Vector3::repeat(f64::NEG_INFINITY);
        for (n, x) in setup.mesh.nodes().iter().enumerate() {
            let moved =
                x + Vector3::new(reference[3 * n], reference[3 * n + 1], reference[3 * n + 2]);
            low = low.inf(x).inf(&moved);
            high = high.sup(x).sup(&moved);
        }
        match contact {
            Some(c) => view_box(c, (low, high)),
            None => (low, high),
        }
    });
    let auto_scale = s.deformation_scale <= 0.0 && !nonlinear;
    Ok(PngLook {
        scale,
        range: (0.0, if high > 0.0 { high } else { 1.0 }),
        field: s.png_field,
        view_box,
        auto_scale,
        scale_for: foreseen,
        size,
    })
}

/// The largest prescribed displacement |u_c(t)| (m) of a moving support node over the sampled
/// frame times (0 without moving supports).
fn prescribed_peak<E: SceneElement>(setup: &DynamicSetup<E>, frame_times: &[f64]) -> Result<f64> {
    if !setup.system.has_moving_supports() {
        return Ok(0.0);
    }
    let stride = frame_times.len().div_ceil(LOOK_MOTION_SAMPLES).max(1);
    let free = vec![0.0; setup.system.free_count()];
    let mut peak = 0.0f64;
    for &t in frame_times.iter().step_by(stride) {
        let u = setup.system.expand_at(t, &free)?;
        peak = displacement_magnitude(&u).into_iter().fold(peak, f64::max);
    }
    Ok(peak)
}
/// The diagonal of the mesh's bounding box (length units).
fn body_size<C: CellType>(mesh: &TetMesh<C>) -> f64 {
    let (mut low, mut high) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for x in mesh.nodes() {
        low = low.inf(x);
        high = high.sup(x);
    }
    (high - low).norm()
}

/// The camera box `(low, high)` of a body's frames grown to hold where the body meets the
/// obstacles at rest: a sphere's or box's bounding box, and for a half-space the body's box
/// corners projected onto its plane (so a falling body and the ground below it stay in view).
fn view_box(
    contact: &Contact,
    (mut low, mut high): (Vector3<f64>, Vector3<f64>),
) -> (Vector3<f64>, Vector3<f64>) {
    let corners: Vec<Vector3<f64>> = (0..8)
        .map(|k| {
            Vector3::new(
                if k & 1 == 0 { low.x } else { high.x },
                if k & 2 == 0 { low.y } else { high.y },
                if k & 4 == 0 { low.z } else { high.z },
            )
        })
        .collect();
    for o in contact.obstacles() {
        let points: Vec<Vector3<f64>> = match *o.shape() {
            Shape::HalfSpace { point, normal } => corners
                .iter()
                .map(|x| x - normal * normal.dot(&(x - point)))
                .collect(),
            Shape::Sphere { center, radius } => {
                vec![center.add_scalar(-radius), center.add_scalar(radius)]
            }
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => {
                let reach = rotation.matrix().abs() * half_extents;
                vec![center - reach, center + reach]
            }
        };
        for p in points {
            low = low.inf(&p);
            high = high.sup(&p);
        }
    }
    (low, high)
}
