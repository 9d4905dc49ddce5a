//! Obstacles for ParaView: the surfaces of contact obstacles where they are at a frame's time, as
//! one VTK PolyData file (`.vtp`) per frame, beside the body's `.vtu` frames. A half-space is
//! drawn as a square tile of its plane around the body, a sphere as a latitude-longitude
//! sphere, a box as its six faces; the cell field `obstacle` numbers them in the given order.

use std::io::Write;
use std::path::Path;

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::contact::{Obstacle, Shape};

/// Rings of quads between a drawn sphere's poles (its latitudes, poles included as points).
const SPHERE_RINGS: usize = 12;
/// Segments around a drawn sphere (its longitudes).
const SPHERE_SEGMENTS: usize = 24;

/// A surface as points and polygons (each a list of point indices, counter-clockwise seen from
/// outside the obstacle).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObstacleSurface {
    /// The points (length).
    pub points: Vec<Vector3<f64>>,
    /// The polygons: triangles and quads.
    pub polygons: Vec<Vec<usize>>,
}

/// The surface of `obstacle` at time `time` (its motion applied). A half-space, which has no
/// edge, is drawn as the square of side `tile` (length) of its plane centred where `center`
/// projects onto it (the body's centre and a size a few times the body's suit).
pub fn obstacle_surface(
    obstacle: &Obstacle,
    time: f64,
    center: Vector3<f64>,
    tile: f64,
) -> ObstacleSurface {
    let offset = obstacle.offset(time);
    match *obstacle.shape() {
        Shape::HalfSpace { point, normal } => {
            let point = point + offset;
            let middle = center - normal * normal.dot(&(center - point));
            // A tangent: n × the axis least aligned with n (never parallel to it).
            let axis = (0..3)
                .min_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
                .map_or(Vector3::x(), |a| Vector3::ith(a, 1.0));
            let t1 = normal.cross(&axis).normalize() * (0.5 * tile);
            let t2 = normal.cross(&t1);
            ObstacleSurface {
                points: vec![
                    middle - t1 - t2,
                    middle + t1 - t2,
                    middle + t1 + t2,
                    middle - t1 + t2,
                ],
                polygons: vec![vec![0, 1, 2, 3]],
            }
        }
        Shape::Sphere { center, radius } => sphere_surface(center + offset, radius),
        Shape::Box {
            center,
            half_extents,
            rotation,
        } => {
            let points = (0..8)
                .map(|k| {
                    let sign = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                    let local = Vector3::new(
                        sign(0) * half_extents.x,
                        sign(1) * half_extents.y,
                        sign(2) * half_extents.z,
                    );
                    center + offset + rotation * local
                })
                .collect();
            // Corner k has bit a set where it is on the + side of axis a.
            let polygons = [
                [0, 4, 6, 2],
                [1, 3, 7, 5],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 2, 3, 1],
                [4, 5, 7, 6],
            ]
            .map(|q| q.to_vec())
            .to_vec();
            ObstacleSurface { points, polygons }
        }
    }
}

/// A latitude-longitude sphere: the two poles, [`SPHERE_RINGS`] − 1 rings of
/// [`SPHERE_SEGMENTS`] points, triangles at the poles and quads between the rings.
fn sphere_surface(center: Vector3<f64>, radius: f64) -> ObstacleSurface {
    use std::f64::consts::PI;
    let (rings, segments) = (SPHERE_RINGS, SPHERE_SEGMENTS);
    let mut points = vec![center + Vector3::new(0.0, 0.0, radius)];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            points.push(
                center
                    + radius
                        * Vector3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        ),
            );
        }
    }
    points.push(center - Vector3::new(0.0, 0.0, radius));
    let south = points.len() - 1;
    let at = |ring: usize, j: usize| 1 + (ring - 1) * segments + j % segments;
    let mut polygons = Vec::new();
    for j in 0..segments {
        polygons.push(vec![0, at(1, j), at(1, j + 1)]);
        for ring in 1..rings - 1 {
            polygons.push(vec![
                at(ring, j),
                at(ring + 1, j),
                at(ring + 1, j + 1),
                at(ring, j + 1),
            ]);
        }
        polygons.push(vec![at(rings - 1, j), south, at(rings - 1, j + 1)]);
    }
    ObstacleSurface { points, polygons }
}

/// Writes the surfaces of `obstacles` at time `time` (see [`obstacle_surface`]; `center` and
/// `tile` place a half-space's tile) as one ASCII VTK PolyData file at `path`, atomically, with
/// the cell field `obstacle` (Int32: the obstacle's index in `obstacles`) and the field data
/// `TimeValue` (`time`). Errors: a non-finite point (an obstacle moved to infinity) is an
/// [`Error::InvalidParameter`]; a write failure an [`Error::Io`] naming the path.
pub fn write_obstacles_vtp(
    path: &Path,
    obstacles: &[Obstacle],
    time: f64,
    center: Vector3<f64>,
    tile: f64,
) -> Result<()> {
    let surfaces: Vec<ObstacleSurface> = obstacles
        .iter()
        .map(|o| obstacle_surface(o, time, center, tile))
        .collect();
    if let Some((o, _)) = obstacles
        .iter()
        .zip(&surfaces)
        .find(|(_, s)| s.points.iter().any(|p| !p.iter().all(|c| c.is_finite())))
    {
        return Err(Error::invalid_parameter(
            format!("obstacle {}", o.name()),
            format!("its surface at t = {time:e}"),
            "must have finite coordinates to be written",
        ));
    }
    crate::base::atomic_file::write_atomically(path, |out| write_polydata(out, &surfaces, time))
}

/// The PolyData XML of `surfaces` (see [`write_obstacles_vtp`]).
fn write_polydata(
    out: &mut dyn Write,
    surfaces: &[ObstacleSurface],
    time: f64,
) -> std::io::Result<()> {
    let points: usize = surfaces.iter().map(|s| s.points.len()).sum();
    let polygons: usize = surfaces.iter().map(|s| s.polygons.len()).sum();
    writeln!(out, r#"<?xml version="1.0"?>"#)?;
    writeln!(
        out,
        r#"<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">"#
    )?;
    writeln!(out, "  <PolyData>")?;
    writeln!(out, "    <FieldData>")?;
    writeln!(
        out,
        r#"      <DataArray type="Float64" Name="TimeValue" NumberOfTuples="1" format="ascii">{time:e}</DataArray>"#
    )?;
    writeln!(out, "    </FieldData>")?;
    writeln!(
        out,
        r#"    <Piece NumberOfPoints="{points}" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="{polygons}">"#
    )?;
    writeln!(out, "      <Points>")?;
    writeln!(
        out,
        r#"        <DataArray type="Float64" NumberOfComponents="3" format="ascii">"#
    )?;
    for p in surfaces.iter().flat_map(|s| &s.points) {
        writeln!(out, "          {:e} {:e} {:e}", p.x, p.y, p.z)?;
    }
    writeln!(out, "        </DataArray>")?;
    writeln!(out, "      </Points>")?;
    writeln!(out, "      <CellData Scalars=\"obstacle\">")?;
    writeln!(
        out,
        r#"        <DataArray type="Int32" Name="obstacle" format="ascii">"#
    )?;
    for (i, s) in surfaces.iter().enumerate() {
        for _ in &s.polygons {
            writeln!(out, "          {i}")?;
        }
    }
    writeln!(out, "        </DataArray>")?;
    writeln!(out, "      </CellData>")?;
    writeln!(out, "      <Polys>")?;
    writeln!(
        out,
        r#"        <DataArray type="Int64" Name="connectivity" format="ascii">"#
    )?;
    let mut first = 0;
    for s in surfaces {
        for polygon in &s.polygons {
            let ids: Vec<String> = polygon.iter().map(|i| (first + i).to_string()).collect();
            writeln!(out, "          {}", ids.join(" "))?;
        }
        first += s.points.len();
    }
    writeln!(out, "        </DataArray>")?;
    writeln!(
        out,
        r#"        <DataArray type="Int64" Name="offsets" format="ascii">"#
    )?;
    let mut end = 0;
    for polygon in surfaces.iter().flat_map(|s| &s.polygons) {
        end += polygon.len();
        writeln!(out, "          {end}")?;
    }
    writeln!(out, "        </DataArray>")?;
    writeln!(out, "      </Polys>")?;
    writeln!(out, "    </Piece>")?;
    writeln!(out, "  </PolyData>")?;
    writeln!(out, "</VTKFile>")
}
