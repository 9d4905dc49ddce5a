//! The boundary surface of a tet mesh as the contact code sees it: outward triangles, their
//! unique edges and vertices (mesh node ids), and what touches what.

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::contact::set::contact_faces;
use crate::mesh::{CellType, TetMesh};

/// A closed, manifold, consistently oriented triangle surface over mesh nodes.
///
/// On 4-node tets the triangles are the boundary faces; on 10-node tets each quadratic face is
/// its four linear sub-triangles (split at the mid-edge nodes, [`contact_faces`]), so contact is
/// measured on the straight-sided P2 surface. Every vertex, edge and triangle names mesh nodes,
/// so a position array indexed by node id (length) serves every query.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Triangles (n₀, n₁, n₂), ordered so that (x₁−x₀)×(x₂−x₀) points out of the body.
    triangles: Vec<[usize; 3]>,
    /// Unique edges (a, b), a < b, sorted.
    edges: Vec<[usize; 2]>,
    /// Surface nodes, ascending.
    vertices: Vec<usize>,
    /// |e|² of each edge at rest (length²): the scale of the edge–edge mollifier.
    rest_edge_length2: Vec<f64>,
    /// Triangles around each vertex (CSR over `vertices`): offsets, then triangle indices.
    vertex_triangle_offsets: Vec<usize>,
    vertex_triangles: Vec<usize>,
}

impl Surface {
    /// The contact surface of `mesh` (see [`Surface`]), at the mesh's node positions as rest.
    ///
    /// Errors: those of [`TetMesh::boundary_faces`]; a surface that is not closed or not
    /// manifold (see [`from_triangles`](Self::from_triangles)).
    pub fn from_mesh<C: CellType>(mesh: &TetMesh<C>) -> Result<Self> {
        let triangles = contact_faces(mesh)?.into_iter().map(|f| f.nodes).collect();
        Self::from_triangles(triangles, mesh.nodes())
    }

    /// The surface of these triangles (node ids into `rest`, rest positions in length units).
    ///
    /// Checks, before anything else is built: every node id is in `rest`
    /// ([`Error::UnknownNode`]); no triangle repeats a node; every edge is shared by exactly two
    /// triangles that run along it in opposite directions — a closed, manifold, consistently
    /// oriented surface. An edge that is not is [`Error::InvalidParameter`] naming the edge
    /// (its two node ids) and how many triangles share it (1: a hole; 3 or more: a non-manifold
    /// seam; 2 in one direction: a flipped triangle).
    pub fn from_triangles(triangles: Vec<[usize; 3]>, rest: &[Vector3<f64>]) -> Result<Self> {
        for tri in &triangles {
            for &n in tri {
                if n >= rest.len() {
                    return Err(Error::UnknownNode {
                        context: "surface triangle",
                        node: n,
                        node_count: rest.len(),
                    });
                }
            }
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                return Err(Error::invalid_parameter(
                    "surface triangle",
                    format!("{tri:?}"),
                    "three distinct nodes",
                ));
            }
        }
        let edges = unique_edges(&triangles)?;
        let mut vertices: Vec<usize> = triangles.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let rest_edge_length2 = edges
            .iter()
            .map(|&[a, b]| (rest[b] - rest[a]).norm_squared())
            .collect();
        let mut counts = vec![0usize; vertices.len() + 1];
        for tri in &triangles {
            for n in tri {
                counts[vertices.binary_search(n).unwrap_or(0) + 1] += 1;
            }
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let mut fill = counts.clone();
        let mut vertex_triangles = vec![0; counts[vertices.len()]];
        for (t, tri) in triangles.iter().enumerate() {
            for n in tri {
                let v = vertices.binary_search(n).unwrap_or(0);
                vertex_triangles[fill[v]] = t;
                fill[v] += 1;
            }
        }
        Ok(Surface {
            triangles,
            edges,
            vertices,
            rest_edge_length2,
            vertex_triangle_offsets: counts,
            vertex_triangles,
        })
    }

    /// The triangles, outward oriented (mesh node ids).
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// The unique edges (a, b), a < b, sorted (mesh node ids).
    pub fn edges(&self) -> &[[usize; 2]] {
        &self.edges
    }

    /// The surface's nodes, ascending (mesh node ids).
    pub fn vertices(&self) -> &[usize] {
        &self.vertices
    }

    /// |b − a|² of edge `e` at rest (length²); `None` for an edge the surface does not have.
    pub fn rest_edge_length2(&self, e: usize) -> Option<f64> {
        self.rest_edge_length2.get(e).copied()
    }

    /// The shortest edge at rest (length; +∞ for an empty surface): an activation distance d̂
    /// above it lets the barrier reach across a single element.
    pub fn shortest_rest_edge(&self) -> f64 {
        self.rest_edge_length2
            .iter()
            .fold(f64::INFINITY, |m, &l| m.min(l))
            .sqrt()
    }

    /// The triangles that have mesh node `node` as a corner (empty for a node off the surface).
    pub fn triangles_around(&self, node: usize) -> &[usize] {
        match self.vertices.binary_search(&node) {
            Ok(v) => {
                &self.vertex_triangles
                    [self.vertex_triangle_offsets[v]..self.vertex_triangle_offsets[v + 1]]
            }
            Err(_) => &[],
        }
    }

    /// Whether point `node` and triangle `t` share a vertex (the node is a corner of `t`): such
    /// a pair is adjacent by topology and never a contact pair. `false` for a triangle the
    /// surface does not have.
    pub fn point_triangle_adjacent(&self, node: usize, t: usize) -> bool {
        self.triangles.get(t).is_some_and(|t| t.contains(&node))
    }

    /// Whether edges `a` and `b` share a vertex (or are the same edge): adjacent by topology.
    /// `false` for an edge the surface does not have.
    pub fn edges_adjacent(&self, a: usize, b: usize) -> bool {
        match (self.edges.get(a), self.edges.get(b)) {
            (Some(ea), Some(eb)) => ea.iter().any(|n| eb.contains(n)),
            _ => false,
        }
    }

    /// Whether triangles `a` and `b` share a vertex (or are the same triangle). `false` for a
    /// triangle the surface does not have.
    pub fn triangles_adjacent(&self, a: usize, b: usize) -> bool {
        match (self.triangles.get(a), self.triangles.get(b)) {
            (Some(ta), Some(tb)) => ta.iter().any(|n| tb.contains(n)),
            _ => false,
        }
    }

    /// [`Error::DimensionMismatch`] unless `positions` covers every surface node, and
    /// [`Error::NonFiniteCoordinate`] naming the first surface node with a coordinate that is
    /// NaN or infinite.
    pub fn check_positions(&self, what: &str, positions: &[Vector3<f64>]) -> Result<()> {
        let needed = self.vertices.last().map_or(0, |&n| n + 1);
        if positions.len() < needed {
            return Err(Error::DimensionMismatch {
                what: format!("{what} (positions indexed by node id)"),
                expected: needed,
                found: positions.len(),
            });
        }
        for &n in &self.vertices {
            if let Some(axis) = (0..3).find(|&a| !positions[n][a].is_finite()) {
                return Err(Error::NonFiniteCoordinate {
                    node: n,
                    axis,
                    value: positions[n][axis],
                });
            }
        }
        Ok(())
    }
}

/// The sorted unique edges of closed, manifold, consistently oriented triangles, or the
/// error naming the first edge that is not (see [`Surface::from_triangles`]).
fn unique_edges(triangles: &[[usize; 3]]) -> Result<Vec<[usize; 2]>> {
    // (sorted edge, +1 if it runs a→b with a < b else −1) for every triangle side.
    let mut sides: Vec<([usize; 2], i8)> = Vec::with_capacity(3 * triangles.len());
    for tri in triangles {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            sides.push(([a.min(b), a.max(b)], if a < b { 1 } else { -1 }));
        }
    }
    sides.sort_unstable();
    let mut edges = Vec::with_capacity(sides.len() / 2);
    let mut i = 0;
    while i < sides.len() {
        let mut j = i + 1;
        while j < sides.len() && sides[j].0 == sides[i].0 {
            j += 1;
        }
        let [a, b] = sides[i].0;
        let opposite = j - i == 2 && sides[i].1 != sides[i + 1].1;
        if !opposite {
            return Err(Error::invalid_parameter(
                format!("surface edge ({a}, {b})"),
                format!(
                    "shared by {} triangle{}{}",
                    j - i,
                    if j - i == 1 { "" } else { "s" },
                    if j - i == 2 {
                        " in the same direction"
                    } else {
                        ""
                    }
                ),
                "a closed, manifold, consistently oriented surface: every edge in exactly two \
                 triangles, which run along it in opposite directions",
            ));
        }
        edges.push([a, b]);
        i = j;
    }
    Ok(edges)
}
