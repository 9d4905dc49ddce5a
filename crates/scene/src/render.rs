//! Headless pictures of a deformed body, in pure Rust: the boundary surface displaced by a
//! magnified displacement, projected orthographically, z-buffered, flat-shaded by a light near
//! the eye, coloured by a nodal or per-tet scalar (viridis map), with mesh edges on large
//! triangles, a colour bar, a title and a subtitle (e.g. the time). Text is drawn with the
//! vendored DejaVu Sans font (`assets/fonts`, free licence) through `ab_glyph`; PNGs are
//! encoded with `png`. Rigid obstacles ([`RenderOptions::obstacles`]) are drawn behind the body
//! and named in a legend under the colour bar (`render/obstacles.rs`).

mod obstacles;

use std::path::Path;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use nalgebra::Vector3;

use tetfem::base::error::{Error, Result};
use tetfem::mesh::{BoundaryFace, CellType, TetMesh};
use tetfem::post::output::write_atomically;

pub use obstacles::{
    FRONT_ALPHA, GROUND_DEPTH, GROUND_MARGIN, OBSTACLE_CUT, OBSTACLE_EDGE, OBSTACLE_FILL,
    ObstacleView,
};

static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// The scalar that colours the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Field<'a> {
    /// One value per node, interpolated across each triangle (e.g. |u|).
    Nodes {
        /// Label of the colour bar (with units).
        name: &'a str,
        /// Values, one per node.
        values: &'a [f64],
    },
    /// One value per tet; a boundary triangle takes its tet's value (e.g. von Mises stress).
    Cells {
        /// Label of the colour bar (with units).
        name: &'a str,
        /// Values, one per tet.
        values: &'a [f64],
    },
}

/// How to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Image width (pixels, 200…8192).
    pub width: u32,
    /// Image height (pixels, 150…8192).
    pub height: u32,
    /// Title line.
    pub title: String,
    /// Second line (time, scale...).
    pub subtitle: String,
    /// Displacement magnification (≥ 0; see [`auto_deformation_scale`]).
    pub deformation_scale: f64,
    /// Camera azimuth around +z (degrees; −60 looks from +x, −y).
    pub azimuth_deg: f64,
    /// Camera elevation above the xy plane (degrees).
    pub elevation_deg: f64,
    /// Colour range; `None`: the field's min and max.
    pub range: Option<(f64, f64)>,
    /// A world box (min and max corners, length units) the view always contains besides the
    /// deformed body: the frames of a run then share one camera instead of each zooming onto
    /// its own shape. `None`: fit the deformed body alone.
    pub view_box: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Rigid obstacles drawn behind the body, each placed where it is at the frame's time
    /// ([`ObstacleView::at`]), named in a legend under the colour bar. They leave the framing
    /// to the body (and `view_box`) unless one would fall wholly outside the plot: then the
    /// view grows to hold it.
    pub obstacles: Vec<ObstacleView>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 960,
            height: 600,
            title: String::new(),
            subtitle: String::new(),
            deformation_scale: 1.0,
            azimuth_deg: -60.0,
            elevation_deg: 25.0,
            range: None,
            view_box: None,
            obstacles: Vec::new(),
        }
    }
}

/// The background colour (white).
pub const BACKGROUND: [u8; 3] = [255, 255, 255];

/// An RGB image, 8 bits per channel, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// `3·width·height` bytes, RGB.
    pub pixels: Vec<u8>,
    /// What the picture shows, as (keyword, text) pairs written as PNG `iTXt` (UTF-8 text) chunks: [`render`]
    /// records the field, the colour bar's range and the deformation scale (see
    /// [`PNG_TEXT_RANGE`]), so that a program can read what a picture's colours mean.
    pub text: Vec<(String, String)>,
}

/// The `iTXt` keyword of a rendered PNG's colour bar range: "low high", in the field's units.
pub const PNG_TEXT_RANGE: &str = "tetfem:colour_range";
/// The `iTXt` keyword of a rendered PNG's field name (e.g. "|u| (m)").
pub const PNG_TEXT_FIELD: &str = "tetfem:field";
/// The `iTXt` keyword of a rendered PNG's deformation scale (the magnification of u).
pub const PNG_TEXT_SCALE: &str = "tetfem:deformation_scale";

impl Image {
    fn new(width: u32, height: u32) -> Image {
        let mut pixels = Vec::with_capacity(3 * width as usize * height as usize);
        for _ in 0..width as usize * height as usize {
            pixels.extend_from_slice(&BACKGROUND);
        }
        Image {
            width,
            height,
            pixels,
            text: Vec::new(),
        }
    }

    /// The pixel at (x, y), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]])
    }

    fn blend(&mut self, x: i64, y: i64, color: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        let a = alpha.clamp(0.0, 1.0);
        for (slot, &target) in self.pixels[i..i + 3].iter_mut().zip(&color) {
            let old = *slot as f32;
            *slot = (old + (target as f32 - old) * a).round() as u8;
        }
    }

    fn fill_rect(&mut self, x0: i64, y0: i64, x1: i64, y1: i64, color: [u8; 3]) {
        for y in y0..y1 {
            for x in x0..x1 {
                self.blend(x, y, color, 1.0);
            }
        }
    }

    /// Encodes the image as PNG (RGB, 8 bits) at `path`, atomically.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        write_atomically(path, |out| {
            let mut encoder = png::Encoder::new(out, self.width, self.height);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            for (keyword, text) in &self.text {
                encoder
                    .add_itxt_chunk(keyword.clone(), text.clone())
                    .map_err(std::io::Error::other)?;
            }
            let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
            writer
                .write_image_data(&self.pixels)
                .map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        })
    }
}

/// A magnification that draws the largest displacement as 10 % of the bounding-box diagonal,
/// never below 1 (a visibly deformed body is drawn true to scale); 1 when nothing moves.
pub fn auto_deformation_scale<C: CellType>(mesh: &TetMesh<C>, displacement: &[f64]) -> f64 {
    let (lo, hi) = mesh.bounding_box();
    let size = (hi - lo).norm();
    let largest = displacement
        .chunks_exact(3)
        .map(|u| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt())
        .fold(0.0f64, f64::max);
    if largest > 0.0 && largest.is_finite() {
        (0.1 * size / largest).max(1.0)
    } else {
        1.0
    }
}

/// Viridis, sampled at nine points and interpolated linearly; `t` in [0, 1].
pub fn viridis(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let x = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * 8.0;
    let i = (x.floor() as usize).min(7);
    let f = x - i as f64;
    let mut c = [0u8; 3];
    for k in 0..3 {
        c[k] = (STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f).round() as u8;
    }
    c
}

/// The flat triangles a boundary face is drawn as, each ordered as the face (outward): the face
/// itself for a 3-node face; a 6-node face (corners a, b, c, then the nodes of edges ab, bc, ca)
/// as its four sub-triangles, so that the drawn surface bends with the quadratic displacement
/// of its edge nodes.
fn face_triangles(nodes: &[usize]) -> Vec<[usize; 3]> {
    match *nodes {
        [a, b, c, ab, bc, ca] => vec![[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]],
        [a, b, c, ..] => vec![[a, b, c]],
        _ => Vec::new(),
    }
}

/// The orthographic camera of a picture: where a world point lands in the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Unit vector from the scene towards the eye (world).
    pub eye: Vector3<f64>,
    /// The image's x axis (to the right) in the world, unit.
    pub right: Vector3<f64>,
    /// The image's up axis in the world, unit (image rows grow downwards).
    pub up: Vector3<f64>,
    /// Pixels per length unit.
    pub zoom: f64,
    /// The pixel the framed middle lands on.
    centre: (f64, f64),
    /// The framed middle along `right` and `up` (length).
    middle: (f64, f64),
}

impl View {
    /// The camera of `options`' azimuth and elevation, not yet framed.
    fn axes(options: &RenderOptions) -> View {
        let (az, el) = (
            options.azimuth_deg.to_radians(),
            options.elevation_deg.to_radians(),
        );
        let eye = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let right = Vector3::z().cross(&eye).normalize();
        let up = eye.cross(&right);
        View {
            eye,
            right,
            up,
            zoom: 1.0,
            centre: (0.0, 0.0),
            middle: (0.0, 0.0),
        }
    }

    /// The same camera zoomed so that `bounds` = [min along right, min along up, max along
    /// right, max along up] (length) fills 95 % of the plot rectangle `plot` = [x0, y0, x1, y1]
    /// (pixels), centred.
    fn fitted(self, bounds: [f64; 4], plot: [f64; 4]) -> View {
        let extent_x = (bounds[2] - bounds[0]).max(1e-300);
        let extent_y = (bounds[3] - bounds[1]).max(1e-300);
        View {
            zoom: ((plot[2] - plot[0]) / extent_x).min((plot[3] - plot[1]) / extent_y) * 0.95,
            centre: (0.5 * (plot[0] + plot[2]), 0.5 * (plot[1] + plot[3])),
            middle: (0.5 * (bounds[0] + bounds[2]), 0.5 * (bounds[1] + bounds[3])),
            ..self
        }
    }

    /// The image position of world point `p` (pixels; x to the right, y down; pixel (i, j)
    /// covers [i, i + 1) × [j, j + 1)): x = c_x + (p·right − m_x)·zoom,
    /// y = c_y − (p·up − m_y)·zoom.
    pub fn screen(&self, p: &Vector3<f64>) -> (f64, f64) {
        (
            self.centre.0 + (p.dot(&self.right) - self.middle.0) * self.zoom,
            self.centre.1 - (p.dot(&self.up) - self.middle.1) * self.zoom,
        )
    }

    /// p·eye (length): larger is nearer the eye.
    pub fn depth(&self, p: &Vector3<f64>) -> f64 {
        p.dot(&self.eye)
    }
}

/// The plot rectangle [x0, y0, x1, y1] (pixels) of a `w` × `h` picture: below the title band,
/// left of the colour bar.
fn plot_area(w: u32, h: u32) -> [f64; 4] {
    [20.0, 70.0, w as f64 - 150.0, h as f64 - 20.0]
}

/// Checks what [`render`] and [`view`] share: the image size, the displacement, the scale.
fn check_inputs<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    options: &RenderOptions,
) -> Result<()> {
    let (w, h) = (options.width, options.height);
    if !(200..=8192).contains(&w) || !(150..=8192).contains(&h) {
        return Err(Error::invalid_parameter(
            "image size",
            format!("{w}×{h}"),
            "must be within [200, 8192] × [150, 8192] pixels",
        ));
    }
    if displacement.len() != mesh.dof_count() || displacement.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid_parameter(
            "displacement",
            format!("{} values", displacement.len()),
            format!("must hold {} finite values (3 per node)", mesh.dof_count()),
        ));
    }
    let scale = options.deformation_scale;
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(Error::invalid_parameter(
            "deformation_scale",
            scale,
            "must be finite and ≥ 0",
        ));
    }
    Ok(())
}

/// The nodes of `mesh` displaced by `scale · displacement`.
fn deformed_nodes<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    scale: f64,
) -> Vec<Vector3<f64>> {
    mesh.nodes()
        .iter()
        .enumerate()
        .map(|(n, p)| {
            p + Vector3::new(
                displacement[3 * n],
                displacement[3 * n + 1],
                displacement[3 * n + 2],
            ) * scale
        })
        .collect()
}

/// The camera [`render`] draws `mesh` displaced by `deformation_scale · displacement` with,
/// and the world box it frames (the deformed boundary and `view_box`), from which a
/// half-space's tile is laid out.
///
/// Framing: the deformed boundary's and `view_box`'s screen box fills 95 % of the plot; an
/// obstacle whose outline (a sphere's disc, a box's corners, a half-space's tile) falls
/// wholly outside the plot is then added to the box and the view fitted again.
///
/// Errors: those of [`render`] (size, displacement, scale).
pub fn view<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    options: &RenderOptions,
) -> Result<View> {
    check_inputs(mesh, displacement, options)?;
    let boundary = mesh.boundary_faces()?;
    let deformed = deformed_nodes(mesh, displacement, options.deformation_scale);
    Ok(frame(&deformed, &boundary, options).0)
}

/// [`view`] on the deformed nodes, with the framed world box.
fn frame(
    deformed: &[Vector3<f64>],
    boundary: &[tetfem::mesh::BoundaryFace],
    options: &RenderOptions,
) -> (View, obstacles::Framed) {
    let camera = View::axes(options);
    let plot = plot_area(options.width, options.height);
    let mut bounds = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut world = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    let add = |p: &Vector3<f64>, bounds: &mut [f64; 4]| {
        let (sx, sy) = (p.dot(&camera.right), p.dot(&camera.up));
        *bounds = [
            bounds[0].min(sx),
            bounds[1].min(sy),
            bounds[2].max(sx),
            bounds[3].max(sy),
        ];
    };
    for f in boundary {
        for &n in &f.nodes {
            add(&deformed[n], &mut bounds);
            world = (world.0.inf(&deformed[n]), world.1.sup(&deformed[n]));
        }
    }
    if let Some((low, high)) = options.view_box {
        for corner in 0..8 {
            let pick = |bit: usize, a: usize| {
                if corner >> bit & 1 == 0 {
                    low[a]
                } else {
                    high[a]
                }
            };
            let p = Vector3::new(pick(0, 0), pick(1, 1), pick(2, 2));
            add(&p, &mut bounds);
            world = (world.0.inf(&p), world.1.sup(&p));
        }
    }
    let fitted = camera.fitted(bounds, plot);
    let mut grown = false;
    for o in &options.obstacles {
        let points = obstacles::outline_points(o, &fitted, world);
        let screen: Vec<(f64, f64)> = points.iter().map(|p| fitted.screen(p)).collect();
        let outside = screen.iter().all(|s| s.0 < plot[0])
            || screen.iter().all(|s| s.0 > plot[2])
            || screen.iter().all(|s| s.1 < plot[1])
            || screen.iter().all(|s| s.1 > plot[3]);
        if outside && !screen.is_empty() {
            for p in &points {
                add(p, &mut bounds);
            }
            grown = true;
        }
    }
    match grown {
        true => (camera.fitted(bounds, plot), world),
        false => (fitted, world),
    }
}

/// The colour bar's range of `field` on `mesh`: `range` if given, else the values' own; checks
/// that the field holds one finite value per node (or per tet), naming it otherwise.
fn colour_range<C: CellType>(
    mesh: &TetMesh<C>,
    field: &Field,
    range: Option<(f64, f64)>,
) -> Result<(f64, f64)> {
    let (name, values, expected) = match field {
        Field::Nodes { name, values } => (*name, *values, mesh.node_count()),
        Field::Cells { name, values } => (*name, *values, mesh.tet_count()),
    };
    if values.len() != expected || values.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid_parameter(
            format!("field '{name}'"),
            format!("{} values", values.len()),
            format!("must hold {expected} finite values"),
        ));
    }
    Ok(range.unwrap_or_else(|| {
        values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            })
    }))
}

/// Draws `mesh` displaced by `deformation_scale · displacement` and coloured by `field`, with
/// the obstacles of `options` behind it (see [`view`] for the framing).
///
/// Errors: a displacement or field of the wrong length, non-finite values, or a size outside
/// the allowed range.
pub fn render<C: CellType>(
    mesh: &TetMesh<C>,
    displacement: &[f64],
    field: &Field,
    options: &RenderOptions,
) -> Result<Image> {
    check_inputs(mesh, displacement, options)?;
    let (w, h) = (options.width, options.height);
    let (name, values, per_node) = match field {
        Field::Nodes { name, values } => (*name, *values, true),
        Field::Cells { name, values } => (*name, *values, false),
    };
    let (lo_value, hi_value) = colour_range(mesh, field, options.range)?;
    let span = if hi_value - lo_value > 1e-300 {
        hi_value - lo_value
    } else {
        1.0
    };
    let colouring = Colouring {
        values,
        per_node,
        lo: lo_value,
        span,
    };

    let boundary = mesh.boundary_faces()?;
    let deformed = deformed_nodes(mesh, displacement, options.deformation_scale);
    let (view, framed) = frame(&deformed, &boundary, options);
    let (right, up, eye) = (view.right, view.up, view.eye);
    let light = (eye + up * 0.5 - right * 0.3).normalize();

    let mut image = Image::new(w, h);
    image.text = png_text(name, lo_value, hi_value, options.deformation_scale);
    // Half-spaces first, the body over them, then spheres and boxes against the body's depth
    // (render/obstacles.rs). Obstacles stay below the subtitle and left of the colour bar's
    // labels.
    let clip = obstacles::Clip {
        x0: 0,
        y0: 64,
        x1: w as i64 - 145,
        y1: h as i64,
    };
    obstacles::draw_grounds(&mut image, &view, &options.obstacles, framed, clip);
    let depth = draw_body(
        &mut image, mesh, &boundary, &deformed, &view, &light, &colouring,
    )?;
    obstacles::draw_solids(
        &mut image,
        &depth,
        &view,
        &options.obstacles,
        (&light, framed),
        clip,
    );

    let legend = obstacles::legend_rows(options.obstacles.len(), h);
    let bar_bottom = h as f64 - 40.0 - obstacles::LEGEND_ROW * legend as f64;
    draw_colour_bar(&mut image, bar_bottom as i64);
    let font = FontRef::try_from_slice(FONT_BYTES).map_err(|e| {
        Error::invalid_parameter("embedded font", e, "must be a valid TrueType font")
    })?;
    draw_titles(&mut image, &font, options);
    let bar_x = w as f64 - 130.0;
    draw_bar_labels(
        &mut image,
        &font,
        name,
        (lo_value, hi_value),
        bar_x,
        bar_bottom,
    );
    obstacles::draw_legend(
        &mut image,
        &font,
        &options.obstacles,
        legend,
        bar_x,
        bar_bottom + 18.0,
    );
    Ok(image)
}

/// How the body's faces are coloured: by node values (interpolated) or by tet values
/// (constant over a face), mapped linearly from `lo` over `span` onto the colour bar.
struct Colouring<'a> {
    values: &'a [f64],
    per_node: bool,
    lo: f64,
    span: f64,
}

/// The PNG text chunks that let a reader of the image recover what it shows: the field's
/// name, its colour range and the deformation scale.
fn png_text(name: &str, lo_value: f64, hi_value: f64, scale: f64) -> Vec<(String, String)> {
    vec![
        (PNG_TEXT_FIELD.to_string(), name.to_string()),
        (
            PNG_TEXT_RANGE.to_string(),
            format!("{lo_value:e} {hi_value:e}"),
        ),
        (PNG_TEXT_SCALE.to_string(), format!("{scale:e}")),
    ]
}

/// Rasterizes the deformed boundary faces, shaded by their angle to `light` and coloured by
/// `colouring`; returns the depth buffer, which the solid obstacles are drawn against so that
/// the body hides what lies behind it.
fn draw_body<C: CellType>(
    image: &mut Image,
    mesh: &TetMesh<C>,
    boundary: &[BoundaryFace],
    deformed: &[Vector3<f64>],
    view: &View,
    light: &Vector3<f64>,
    colouring: &Colouring,
) -> Result<Vec<f64>> {
    let to_screen = |p: &Vector3<f64>| {
        let (x, y) = view.screen(p);
        (x, y, view.depth(p))
    };
    let mut depth = vec![f64::NEG_INFINITY; image.width as usize * image.height as usize];
    for face in boundary {
        for triangle in face_triangles(&face.element_nodes(mesh)?) {
            let p = triangle.map(|n| deformed[n]);
            let normal = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let norm = normal.norm();
            if norm <= 0.0 || !norm.is_finite() {
                continue;
            }
            let shade = 0.35 + 0.65 * (normal / norm).dot(light).abs();
            let s = p.map(|q| to_screen(&q));
            let v = if colouring.per_node {
                triangle.map(|n| colouring.values[n])
            } else {
                [colouring.values[face.tet]; 3]
            };
            raster_triangle(
                image,
                &mut depth,
                &s,
                &v,
                shade,
                colouring.lo,
                colouring.span,
            );
        }
    }
    Ok(depth)
}

/// The title and, below it, the subtitle, at the top left.
fn draw_titles(image: &mut Image, font: &FontRef, options: &RenderOptions) {
    draw_text(image, font, &options.title, 20.0, 32.0, 24.0, [20, 20, 20]);
    draw_text(
        image,
        font,
        &options.subtitle,
        20.0,
        56.0,
        16.0,
        [80, 80, 80],
    );
}

/// The field's name above the colour bar at `bar_x` and five values of `range` (lo, hi)
/// with tick marks, evenly from the bar's bottom (`bar_bottom`, pixels) to its top.
fn draw_bar_labels(
    image: &mut Image,
    font: &FontRef,
    name: &str,
    (lo_value, hi_value): (f64, f64),
    bar_x: f64,
    bar_bottom: f64,
) {
    draw_text(image, font, name, bar_x, 56.0, 15.0, [20, 20, 20]);
    let bar_top = 70.0;
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let y = bar_bottom - t * (bar_bottom - bar_top);
        let label = format_number(lo_value + t * (hi_value - lo_value));
        draw_text(
            image,
            font,
            &label,
            bar_x + 30.0,
            y + 5.0,
            13.0,
            [20, 20, 20],
        );
        image.fill_rect(
            bar_x as i64 + 22,
            y as i64,
            bar_x as i64 + 27,
            y as i64 + 1,
            [20, 20, 20],
        );
    }
}

/// Fills one screen triangle with z-buffering, interpolating the scalar; darkens a thin band
/// along the edges of triangles large enough for the edges to read as a mesh.
fn raster_triangle(
    image: &mut Image,
    depth: &mut [f64],
    s: &[(f64, f64, f64); 3],
    v: &[f64; 3],
    shade: f64,
    lo: f64,
    span: f64,
) {
    let (w, h) = (image.width as i64, image.height as i64);
    let area2 = (s[1].0 - s[0].0) * (s[2].1 - s[0].1) - (s[2].0 - s[0].0) * (s[1].1 - s[0].1);
    if area2.abs() < 1e-12 || !area2.is_finite() {
        return;
    }
    let min_x = s
        .iter()
        .map(|p| p.0)
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(0.0) as i64;
    let max_x = (s
        .iter()
        .map(|p| p.0)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil() as i64)
        .min(w - 1);
    let min_y = s
        .iter()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(0.0) as i64;
    let max_y = (s
        .iter()
        .map(|p| p.1)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil() as i64)
        .min(h - 1);
    // Edge lengths (pixels) for the edge band; edge i is opposite vertex i.
    let len = |a: usize, b: usize| ((s[a].0 - s[b].0).powi(2) + (s[a].1 - s[b].1).powi(2)).sqrt();
    let edges = [len(1, 2), len(2, 0), len(0, 1)];
    let show_edges = area2.abs() > 120.0;
    for y in min_y..=max_y {
        for x in min_x..=max_x {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let b0 = ((s[1].0 - px) * (s[2].1 - py) - (s[2].0 - px) * (s[1].1 - py)) / area2;
            let b1 = ((s[2].0 - px) * (s[0].1 - py) - (s[0].0 - px) * (s[2].1 - py)) / area2;
            let b2 = 1.0 - b0 - b1;
            if b0 < -1e-9 || b1 < -1e-9 || b2 < -1e-9 {
                continue;
            }
            let z = b0 * s[0].2 + b1 * s[1].2 + b2 * s[2].2;
            let i = (y * w + x) as usize;
            if z <= depth[i] {
                continue;
            }
            depth[i] = z;
            let value = b0 * v[0] + b1 * v[1] + b2 * v[2];
            let base = viridis((value - lo) / span);
            let mut k = shade;
            if show_edges {
                // Distance (pixels) to edge j is b_j · 2A / |edge_j|.
                let d = [b0, b1, b2]
                    .iter()
                    .zip(edges)
                    .map(|(b, e)| b * area2.abs() / e.max(1e-12))
                    .fold(f64::INFINITY, f64::min);
                if d < 0.6 {
                    k *= 0.7;
                }
            }
            let color = base.map(|c| (c as f64 * k).round().clamp(0.0, 255.0) as u8);
            image.blend(x, y, color, 1.0);
        }
    }
}

/// The colour bar from y = 70 down to `bottom` (pixels), outlined.
fn draw_colour_bar(image: &mut Image, bottom: i64) {
    let x = image.width as i64 - 130;
    let top = 70i64;
    for y in top..=bottom {
        let t = (bottom - y) as f64 / (bottom - top).max(1) as f64;
        image.fill_rect(x, y, x + 22, y + 1, viridis(t));
    }
    image.fill_rect(x - 1, top - 1, x + 23, top, [60, 60, 60]);
    image.fill_rect(x - 1, bottom + 1, x + 23, bottom + 2, [60, 60, 60]);
    image.fill_rect(x - 1, top - 1, x, bottom + 2, [60, 60, 60]);
    image.fill_rect(x + 22, top - 1, x + 23, bottom + 2, [60, 60, 60]);
}

/// Short text for a colour bar label: four significant digits, fixed point for moderate
/// magnitudes, else scientific.
fn format_number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (1e-2..1e4).contains(&a) {
        let decimals = (3 - a.log10().floor() as i64).max(0) as usize;
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.3e}")
    }
}

/// Draws `text` with its baseline at `y`, starting at `x` (anti-aliased).
fn draw_text(
    image: &mut Image,
    font: &FontRef,
    text: &str,
    x: f64,
    y: f64,
    size: f32,
    color: [u8; 3],
) {
    let scale = PxScale::from(size);
    let scaled = font.as_scaled(scale);
    let mut caret = x as f32;
    let mut previous = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            caret += scaled.kern(p, id);
        }
        let glyph = id.with_scale_and_position(scale, point(caret, y as f32));
        caret += scaled.h_advance(id);
        previous = Some(id);
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                image.blend(
                    bounds.min.x as i64 + gx as i64,
                    bounds.min.y as i64 + gy as i64,
                    color,
                    coverage,
                );
            });
        }
    }
}
