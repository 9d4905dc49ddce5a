//! Rigid obstacles in a picture, clipped to the plot, with their names in a legend under the
//! colour bar. The body stays on top: half-spaces seen from the body's side are drawn before it
//! (a body outside a half-space, seen from its side, is never behind it); spheres, boxes and
//! half-spaces seen from their solid side (a platen above a body seen from above) after it
//! against its depth buffer, hidden where the body is nearer the eye and drawn at [`FRONT_ALPHA`] over it
//! where they are nearer, so the body shows through and the overlap reads as in front.
//!
//! - A half-space is drawn as a slab of its boundary: the tile of the plane under everything the
//!   camera frames (the framed box's footprint on the plane, grown by [`GROUND_MARGIN`] of the
//!   box's diagonal on each side) in [`OBSTACLE_FILL`], and [`GROUND_DEPTH`] of the diagonal
//!   below it the slab's cut sides in [`OBSTACLE_CUT`]: from above the ground is a tile, seen
//!   edge-on a line with a filled band below.
//! - A sphere is a shaded disc of its projected radius, outlined.
//! - A box (aligned or turned) is its faces that face the eye, shaded by the light, outlined.

use nalgebra::{Matrix3, Rotation3, Vector3};

use tetfem::contact::{Obstacle, Shape};

use super::{Image, View};

/// The colour of an obstacle's surface: a half-space's boundary plane (exactly), a sphere's and
/// a box's faces (shaded by the light), the legend's swatches. A light warm grey, apart from the
/// viridis colours of the body and from the white background.
pub const OBSTACLE_FILL: [u8; 3] = [214, 204, 186];
/// The colour of a half-space slab's cut sides (exactly): the band below a ground line.
pub const OBSTACLE_CUT: [u8; 3] = [176, 162, 140];
/// The colour of obstacles' outlines.
pub const OBSTACLE_EDGE: [u8; 3] = [105, 92, 74];
/// How far a half-space's tile reaches past the footprint of the framed box on its plane, on
/// every side, as a fraction of the framed box's diagonal (dimensionless).
pub const GROUND_MARGIN: f64 = 0.15;
/// The depth of a half-space's slab below its plane, as a fraction of the framed box's
/// diagonal (dimensionless).
pub const GROUND_DEPTH: f64 = 0.06;

/// An obstacle as drawn in one frame: its name and its shape placed where it is at the frame's
/// time.
#[derive(Debug, Clone, PartialEq)]
pub struct ObstacleView {
    /// The name shown in the legend.
    pub name: String,
    /// The shape at the frame's time (length units).
    pub shape: Shape,
}

impl ObstacleView {
    /// `obstacle` at time `time` (time units): its shape moved by its offset c(t) (zero for a
    /// fixed obstacle; see [`Obstacle::offset`]).
    pub fn at(obstacle: &Obstacle, time: f64) -> ObstacleView {
        let c = obstacle.offset(time);
        let shape = match *obstacle.shape() {
            Shape::HalfSpace { point, normal } => Shape::HalfSpace {
                point: point + c,
                normal,
            },
            Shape::Sphere { center, radius } => Shape::Sphere {
                center: center + c,
                radius,
            },
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => Shape::Box {
                center: center + c,
                half_extents,
                rotation,
            },
        };
        ObstacleView {
            name: obstacle.name().to_string(),
            shape,
        }
    }
}

/// A box as drawn: centre, half extents along its axes (the columns of `rotation`), and
/// whether its face along +axis 3 is a half-space's boundary (drawn in [`OBSTACLE_FILL`], the
/// others in [`OBSTACLE_CUT`], unshaded).
struct Solid {
    center: Vector3<f64>,
    half: Vector3<f64>,
    rotation: Rotation3<f64>,
    ground: bool,
}

/// The world box `(low, high)` the camera frames: a half-space's tile is laid out from it.
pub(super) type Framed = (Vector3<f64>, Vector3<f64>);

/// The slab a half-space through `point` with unit `normal` is drawn as under `framed`.
fn ground_slab(point: Vector3<f64>, normal: Vector3<f64>, (low, high): Framed) -> Solid {
    // In-plane axes: the world axis least along the normal, made orthogonal (x and y for a
    // horizontal ground), and n × e1.
    let axis = (0..3)
        .min_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(0);
    let e1 = (Vector3::ith(axis, 1.0) - normal * normal[axis]).normalize();
    let e2 = normal.cross(&e1);
    let diagonal = (high - low).norm().max(f64::MIN_POSITIVE);
    let (mut a, mut b) = (
        (f64::INFINITY, f64::NEG_INFINITY),
        (f64::INFINITY, f64::NEG_INFINITY),
    );
    for corner in corners(low, high) {
        let (s, t) = (e1.dot(&(corner - point)), e2.dot(&(corner - point)));
        a = (a.0.min(s), a.1.max(s));
        b = (b.0.min(t), b.1.max(t));
    }
    let margin = GROUND_MARGIN * diagonal;
    let depth = GROUND_DEPTH * diagonal;
    Solid {
        center: point + e1 * 0.5 * (a.0 + a.1) + e2 * 0.5 * (b.0 + b.1) - normal * 0.5 * depth,
        half: Vector3::new(
            0.5 * (a.1 - a.0) + margin,
            0.5 * (b.1 - b.0) + margin,
            0.5 * depth,
        ),
        rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[e1, e2, normal])),
        ground: true,
    }
}

/// The eight corners of the world box `low`…`high`.
fn corners(low: Vector3<f64>, high: Vector3<f64>) -> [Vector3<f64>; 8] {
    std::array::from_fn(|k| {
        Vector3::new(
            if k & 1 == 0 { low.x } else { high.x },
            if k & 2 == 0 { low.y } else { high.y },
            if k & 4 == 0 { low.z } else { high.z },
        )
    })
}

impl Solid {
    /// Its six faces: outward normal and four corners in order around the face; the fifth
    /// (index 5) is the face along +axis 3.
    fn faces(&self) -> [(Vector3<f64>, [Vector3<f64>; 4]); 6] {
        let r = self.rotation.matrix();
        let point = |s: [f64; 3]| {
            self.center
                + r.column(0) * s[0] * self.half[0]
                + r.column(1) * s[1] * self.half[1]
                + r.column(2) * s[2] * self.half[2]
        };
        std::array::from_fn(|f| {
            let (axis, sign) = (f / 2, if f % 2 == 0 { -1.0 } else { 1.0 });
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut s = [0.0; 3];
                s[axis] = sign;
                s[u] = a;
                s[v] = b;
                point(s)
            };
            (
                r.column(axis) * sign,
                [
                    corner(-1.0, -1.0),
                    corner(1.0, -1.0),
                    corner(1.0, 1.0),
                    corner(-1.0, 1.0),
                ],
            )
        })
    }
}

/// The solid an obstacle is drawn as (`None` for a sphere, drawn as a disc).
fn solid_of(shape: &Shape, framed: Framed) -> Option<Solid> {
    match *shape {
        Shape::HalfSpace { point, normal } => Some(ground_slab(point, normal, framed)),
        Shape::Sphere { .. } => None,
        Shape::Box {
            center,
            half_extents,
            rotation,
        } => Some(Solid {
            center,
            half: half_extents,
            rotation,
            ground: false,
        }),
    }
}

/// World points whose screen box is where `obstacle` appears: a sphere's centre moved by ±R
/// along the screen axes of `view`, a box's corners, a half-space's slab corners.
pub(super) fn outline_points(
    obstacle: &ObstacleView,
    view: &View,
    framed: Framed,
) -> Vec<Vector3<f64>> {
    match (obstacle.shape, solid_of(&obstacle.shape, framed)) {
        (Shape::Sphere { center, radius }, _) => vec![
            center + view.right * radius,
            center - view.right * radius,
            center + view.up * radius,
            center - view.up * radius,
        ],
        (_, Some(solid)) => solid.faces().iter().flat_map(|(_, c)| *c).collect(),
        (_, None) => Vec::new(),
    }
}

/// The pixel rectangle obstacles are clipped to: `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Clip {
    pub x0: i64,
    pub y0: i64,
    pub x1: i64,
    pub y1: i64,
}

impl Clip {
    fn contains(&self, x: i64, y: i64) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }
}

/// How much of an obstacle's colour covers the body where the obstacle is nearer the eye: the
/// body stays visible through it (drawn on top, dimmed), and the overlap reads as in front.
pub const FRONT_ALPHA: f32 = 0.45;

/// Where obstacle pixels go: the image, clipped, and the body's depth buffer (p·eye per pixel,
/// −∞ where no body is drawn) once the body is drawn.
struct Canvas<'a> {
    image: &'a mut Image,
    depth: Option<&'a [f64]>,
    clip: Clip,
}

impl Canvas<'_> {
    /// Puts an obstacle pixel at depth `z` (p·eye): opaque where no body is drawn, at
    /// [`FRONT_ALPHA`] over a body behind it, nothing over a body in front of it.
    fn put(&mut self, x: i64, y: i64, z: f64, colour: [u8; 3]) {
        if !self.clip.contains(x, y) {
            return;
        }
        let alpha = match self.depth {
            None => 1.0,
            Some(depth) => {
                let body = depth[(y * self.image.width as i64 + x) as usize];
                if body == f64::NEG_INFINITY {
                    1.0
                } else if z > body {
                    FRONT_ALPHA
                } else {
                    return;
                }
            }
        };
        self.image.blend(x, y, colour, alpha);
    }
}

/// Whether the eye sees half-space boundary `normal` (pointing out of the obstacle, to the
/// body's side) from the body's side: a floor seen from above. Then the body, outside the
/// obstacle, is never behind the plane; a platen above a body seen from above is the other
/// case, and is in front of it.
fn seen_from_outside(view: &View, normal: &Vector3<f64>) -> bool {
    view.eye.dot(normal) >= 0.0
}

/// Draws the half-spaces of `obstacles` seen from the body's side (before the body, which is
/// drawn over them: a body outside a half-space, seen from its side, is never behind it); the
/// others are drawn with the solids, over the body ([`draw_solids`]).
pub(super) fn draw_grounds(
    image: &mut Image,
    view: &View,
    obstacles: &[ObstacleView],
    framed: Framed,
    clip: Clip,
) {
    let mut canvas = Canvas {
        image,
        depth: None,
        clip,
    };
    for obstacle in obstacles {
        if let (Shape::HalfSpace { normal, .. }, Some(solid)) =
            (obstacle.shape, solid_of(&obstacle.shape, framed))
            && seen_from_outside(view, &normal)
        {
            draw_solid(&mut canvas, view, &solid, &Vector3::zeros());
        }
    }
}

/// Draws the spheres, boxes and half-spaces seen from their solid side of `obstacles` after
/// the body, whose depth buffer is `depth` (see [`Canvas::put`]); `light` is the unit direction
/// the surfaces are lit from, `framed` what the camera frames (a half-space's tile).
pub(super) fn draw_solids(
    image: &mut Image,
    depth: &[f64],
    view: &View,
    obstacles: &[ObstacleView],
    (light, framed): (&Vector3<f64>, Framed),
    clip: Clip,
) {
    let mut canvas = Canvas {
        image,
        depth: Some(depth),
        clip,
    };
    for obstacle in obstacles {
        match obstacle.shape {
            Shape::HalfSpace { normal, .. } => {
                if let Some(solid) = solid_of(&obstacle.shape, framed)
                    && !seen_from_outside(view, &normal)
                {
                    draw_solid(&mut canvas, view, &solid, &Vector3::zeros());
                }
            }
            Shape::Sphere { center, radius } => {
                draw_sphere(&mut canvas, view, center, radius, light)
            }
            Shape::Box {
                center,
                half_extents,
                rotation,
            } => {
                let solid = Solid {
                    center,
                    half: half_extents,
                    rotation,
                    ground: false,
                };
                draw_solid(&mut canvas, view, &solid, light)
            }
        }
    }
}

/// The faces of `solid` that face the eye (a convex solid's never overlap on screen), filled,
/// then their edges.
fn draw_solid(canvas: &mut Canvas, view: &View, solid: &Solid, light: &Vector3<f64>) {
    let faces = solid.faces();
    let front: Vec<usize> = (0..6)
        .filter(|&f| faces[f].0.dot(&view.eye) > 1e-9)
        .collect();
    let project = |p: &Vector3<f64>| {
        let (x, y) = view.screen(p);
        (x, y, view.depth(p))
    };
    for &f in &front {
        let (normal, quad) = &faces[f];
        let colour = match (solid.ground, f == 5) {
            (true, true) => OBSTACLE_FILL,
            (true, false) => OBSTACLE_CUT,
            (false, _) => shaded(OBSTACLE_FILL, 0.78 + 0.22 * normal.dot(light).max(0.0)),
        };
        let s = quad.map(|p| project(&p));
        fill_triangle(canvas, [s[0], s[1], s[2]], colour);
        fill_triangle(canvas, [s[0], s[2], s[3]], colour);
    }
    for &f in &front {
        let s = faces[f].1.map(|p| project(&p));
        for k in 0..4 {
            draw_line(canvas, s[k], s[(k + 1) % 4], OBSTACLE_EDGE);
        }
    }
}

/// A disc of the sphere's projected radius, shaded as a sphere lit from `light`, outlined;
/// each pixel at the depth of the sphere's near surface.
fn draw_sphere(
    canvas: &mut Canvas,
    view: &View,
    center: Vector3<f64>,
    radius: f64,
    light: &Vector3<f64>,
) {
    let (cx, cy) = view.screen(&center);
    let r = radius * view.zoom;
    if !(r.is_finite() && cx.is_finite() && cy.is_finite()) {
        return;
    }
    let clip = canvas.clip;
    let x0 = ((cx - r - 1.0).floor() as i64).max(clip.x0);
    let x1 = ((cx + r + 1.0).ceil() as i64).min(clip.x1 - 1);
    let y0 = ((cy - r - 1.0).floor() as i64).max(clip.y0);
    let y1 = ((cy + r + 1.0).ceil() as i64).min(clip.y1 - 1);
    let middle = view.depth(&center);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (dx, dy) = ((x as f64 + 0.5 - cx) / r, (cy - y as f64 - 0.5) / r);
            let rho = (dx * dx + dy * dy).sqrt();
            if rho > 1.0 + 1.0 / r {
                continue;
            }
            let height = (1.0 - rho * rho).max(0.0).sqrt();
            let z = middle + radius * height;
            if rho * r > r - 1.0 {
                canvas.put(x, y, z, OBSTACLE_EDGE);
                continue;
            }
            let normal = view.right * dx + view.up * dy + view.eye * height;
            let k = 0.7 + 0.3 * normal.dot(light).max(0.0);
            canvas.put(x, y, z, shaded(OBSTACLE_FILL, k));
        }
    }
}

fn shaded(colour: [u8; 3], k: f64) -> [u8; 3] {
    colour.map(|c| (c as f64 * k).round().clamp(0.0, 255.0) as u8)
}

/// Fills the screen triangle `s` = (x, y, depth) per corner (pixel centres inside it, either
/// orientation), the depth interpolated.
fn fill_triangle(canvas: &mut Canvas, s: [(f64, f64, f64); 3], colour: [u8; 3]) {
    let area2 = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[2].0 - s[0].0) * (s[1].1 - s[0].1);
    if area2.abs() < 1e-12 || !area2.is_finite() {
        return;
    }
    let clip = canvas.clip;
    let lo = |k: usize| {
        s.iter()
            .map(|p| [p.0, p.1][k])
            .fold(f64::INFINITY, f64::min)
    };
    let hi = |k: usize| {
        s.iter()
            .map(|p| [p.0, p.1][k])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let x0 = (lo(0).floor().max(clip.x0 as f64)) as i64;
    let x1 = (hi(0).ceil().min(clip.x1 as f64 - 1.0)) as i64;
    let y0 = (lo(1).floor().max(clip.y0 as f64)) as i64;
    let y1 = (hi(1).ceil().min(clip.y1 as f64 - 1.0)) as i64;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let b0 = ((s[1].0 - px) * (s[2].1 - py) - (s[2].0 - px) * (s[1].1 - py)) / area2;
            let b1 = ((s[2].0 - px) * (s[0].1 - py) - (s[0].0 - px) * (s[2].1 - py)) / area2;
            let b2 = 1.0 - b0 - b1;
            if b0 >= -1e-9 && b1 >= -1e-9 && b2 >= -1e-9 {
                canvas.put(x, y, b0 * s[0].2 + b1 * s[1].2 + b2 * s[2].2, colour);
            }
        }
    }
}

/// A one-pixel line from `a` to `b` (x, y, depth), clipped, the depth interpolated.
fn draw_line(canvas: &mut Canvas, a: (f64, f64, f64), b: (f64, f64, f64), colour: [u8; 3]) {
    let length = (b.0 - a.0).abs().max((b.1 - a.1).abs());
    if !length.is_finite() {
        return;
    }
    // Past a few frames' width a line is clipped anyway: cap the work.
    let steps = (length.ceil() as i64).clamp(1, 100_000);
    for k in 0..=steps {
        let t = k as f64 / steps as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        canvas.put(
            x.floor() as i64,
            y.floor() as i64,
            a.2 + (b.2 - a.2) * t,
            colour,
        );
    }
}

/// The legend rows' height (pixels).
pub(super) const LEGEND_ROW: f64 = 20.0;

/// How many legend rows fit under a colour bar of an image `height` pixels tall (the bar keeps
/// at least 60 pixels).
pub(super) fn legend_rows(count: usize, height: u32) -> usize {
    let room = (height as f64 - 40.0 - 70.0 - 60.0) / LEGEND_ROW;
    count.min(room.max(0.0) as usize)
}

/// Draws the legend's rows from `top` (pixels) at `x`: per obstacle a swatch whose shape says
/// its kind (a ground band for a half-space, a disc for a sphere, a square for a box) and its
/// name; at most `rows` of them (the last saying how many more when they do not fit).
pub(super) fn draw_legend(
    image: &mut Image,
    font: &ab_glyph::FontRef,
    obstacles: &[ObstacleView],
    rows: usize,
    x: f64,
    top: f64,
) {
    for (i, o) in obstacles.iter().take(rows).enumerate() {
        let y = top + LEGEND_ROW * i as f64;
        let (x0, y0) = (x as i64, y as i64);
        match o.shape {
            Shape::HalfSpace { .. } => {
                image.fill_rect(x0, y0 + 5, x0 + 14, y0 + 9, OBSTACLE_FILL);
                image.fill_rect(x0, y0 + 9, x0 + 14, y0 + 14, OBSTACLE_CUT);
                image.fill_rect(x0, y0 + 5, x0 + 14, y0 + 6, OBSTACLE_EDGE);
            }
            Shape::Sphere { .. } => {
                let (cx, cy) = (x + 7.0, y + 7.0);
                for py in y0..y0 + 15 {
                    for px in x0..x0 + 15 {
                        let r = ((px as f64 + 0.5 - cx).powi(2) + (py as f64 + 0.5 - cy).powi(2))
                            .sqrt();
                        if r <= 6.0 {
                            image.blend(px, py, OBSTACLE_FILL, 1.0);
                        } else if r <= 7.0 {
                            image.blend(px, py, OBSTACLE_EDGE, 1.0);
                        }
                    }
                }
            }
            Shape::Box { .. } => {
                image.fill_rect(x0, y0, x0 + 14, y0 + 14, OBSTACLE_EDGE);
                image.fill_rect(x0 + 1, y0 + 1, x0 + 13, y0 + 13, OBSTACLE_FILL);
            }
        }
        let label = match (i + 1 == rows, obstacles.len() - rows) {
            (true, more) if more > 0 => format!("+{} more", more + 1),
            _ => o.name.clone(),
        };
        super::draw_text(image, font, &label, x + 20.0, y + 12.0, 13.0, [20, 20, 20]);
    }
}
