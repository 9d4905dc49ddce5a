//! The broad phase: a bounding-volume hierarchy of axis-aligned boxes over a surface's
//! triangles and edges, which returns the point–triangle and edge–edge pairs whose boxes —
//! inflated by the reach d̂ and swept over a step's motion — overlap. Built in O(n log n)
//! (median splits), each query O(log n + pairs found); the queries run in parallel.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::boundary::Surface;
use crate::base::error::{Error, Result};

/// An axis-aligned box [min, max] (length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The lower corner (length).
    pub min: Vector3<f64>,
    /// The upper corner (length).
    pub max: Vector3<f64>,
}

impl Aabb {
    /// The smallest box holding `points` (an empty box, min = +∞, for none).
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a Vector3<f64>>) -> Self {
        let mut b = Aabb {
            min: Vector3::repeat(f64::INFINITY),
            max: Vector3::repeat(f64::NEG_INFINITY),
        };
        for p in points {
            b.min = b.min.inf(p);
            b.max = b.max.sup(p);
        }
        b
    }

    /// The box grown by `margin` (length) on every side.
    pub fn inflated(self, margin: f64) -> Self {
        Aabb {
            min: self.min.add_scalar(-margin),
            max: self.max.add_scalar(margin),
        }
    }

    /// Whether the closed boxes share a point.
    pub fn overlaps(&self, other: &Aabb) -> bool {
        (0..3).all(|a| self.min[a] <= other.max[a] && other.min[a] <= self.max[a])
    }

    fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: self.min.inf(&other.min),
            max: self.max.sup(&other.max),
        }
    }

    fn centre(&self, axis: usize) -> f64 {
        0.5 * (self.min[axis] + self.max[axis])
    }
}

/// Boxes per leaf: a few, so that the tree is shallow and a leaf test is cheap.
const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone)]
struct Node {
    bbox: Aabb,
    /// Leaf (count > 0): the boxes `order[start..start + count]`; inner node (count 0): the
    /// left child is the next node, the right child is `right`.
    start: usize,
    count: usize,
    right: usize,
}

/// A bounding-volume hierarchy over a list of boxes (median split on the longest axis of the
/// box centres).
#[derive(Debug, Clone)]
pub struct Bvh {
    boxes: Vec<Aabb>,
    order: Vec<usize>,
    nodes: Vec<Node>,
}

impl Bvh {
    /// The hierarchy over `boxes` (indices into it are what queries return).
    pub fn new(boxes: Vec<Aabb>) -> Self {
        let mut bvh = Bvh {
            order: (0..boxes.len()).collect(),
            boxes,
            nodes: Vec::new(),
        };
        if !bvh.boxes.is_empty() {
            bvh.build(0, bvh.boxes.len());
        }
        bvh
    }

    /// Builds the node over `order[start..end]` and returns its index.
    fn build(&mut self, start: usize, end: usize) -> usize {
        let bbox = self.order[start..end]
            .iter()
            .fold(self.boxes[self.order[start]], |b, &i| {
                b.union(&self.boxes[i])
            });
        let index = self.nodes.len();
        self.nodes.push(Node {
            bbox,
            start,
            count: end - start,
            right: 0,
        });
        if end - start <= LEAF_SIZE {
            return index;
        }
        let centres =
            self.order[start..end]
                .iter()
                .fold(Aabb::of_points(std::iter::empty()), |b, &i| {
                    let c = 0.5 * (self.boxes[i].min + self.boxes[i].max);
                    b.union(&Aabb { min: c, max: c })
                });
        let axis = (centres.max - centres.min).imax();
        let mid = (start + end) / 2;
        let boxes = &self.boxes;
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            boxes[a].centre(axis).total_cmp(&boxes[b].centre(axis))
        });
        self.build(start, mid);
        let right = self.build(mid, end);
        self.nodes[index].count = 0;
        self.nodes[index].right = right;
        index
    }

    /// Calls `visit(i)` for every box i that overlaps `query`.
    pub fn query(&self, query: &Aabb, mut visit: impl FnMut(usize)) {
        if self.nodes.is_empty() {
            return;
        }
        // Median splits halve every range, so the depth is at most log₂(n) + 1 and a pending
        // stack of 64 holds any tree (one right sibling per level, plus the root).
        let mut stack = [0usize; 64];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let n = stack[len];
            let node = &self.nodes[n];
            if !node.bbox.overlaps(query) {
                continue;
            }
            if node.count > 0 {
                for &i in &self.order[node.start..node.start + node.count] {
                    if self.boxes[i].overlaps(query) {
                        visit(i);
                    }
                }
            } else {
                // The left child is built right after its parent.
                stack[len] = node.right;
                stack[len + 1] = n + 1;
                len += 2;
            }
        }
    }
}

/// Candidate contact pairs of a surface, none adjacent by topology.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Candidates {
    /// (mesh node of the point, triangle index), sorted.
    pub point_triangle: Vec<(usize, usize)>,
    /// (edge index a, edge index b), a < b, sorted.
    pub edge_edge: Vec<(usize, usize)>,
}

/// The pairs of `surface` whose boxes, each grown by `inflation`/2 (length) and swept from
/// `positions` to `positions + displacement` when a displacement is given, overlap: a superset
/// of the pairs that come within `inflation` of each other along the straight-line motion.
/// Pairs that share a vertex are left out.
///
/// Errors: positions or displacement not covering the surface or not finite (see
/// [`Surface::check_positions`]); `inflation` not finite or negative.
pub fn candidates(
    surface: &Surface,
    positions: &[Vector3<f64>],
    displacement: Option<&[Vector3<f64>]>,
    inflation: f64,
) -> Result<Candidates> {
    surface.check_positions("broad phase", positions)?;
    if let Some(dx) = displacement {
        surface.check_positions("broad phase displacement", dx)?;
    }
    if !(inflation.is_finite() && inflation >= 0.0) {
        return Err(Error::invalid_parameter(
            "broad phase inflation",
            inflation,
            "must be finite and ≥ 0 (length)",
        ));
    }
    let margin = 0.5 * inflation;
    let swept = |nodes: &[usize]| {
        let mut b = Aabb::of_points(nodes.iter().map(|&n| &positions[n]));
        if let Some(dx) = displacement {
            for &n in nodes {
                let end = positions[n] + dx[n];
                b.min = b.min.inf(&end);
                b.max = b.max.sup(&end);
            }
        }
        b.inflated(margin)
    };
    let triangles = Bvh::new(surface.triangles().iter().map(|t| swept(t)).collect());
    let edge_boxes: Vec<Aabb> = surface.edges().iter().map(|e| swept(e)).collect();
    let edges = Bvh::new(edge_boxes.clone());
    // Queries run in parallel on rayon's pool; the sort makes the result independent of it.
    let mut out = Candidates {
        point_triangle: surface
            .vertices()
            .par_iter()
            .flat_map_iter(|&n| {
                let mut found = Vec::new();
                triangles.query(&swept(&[n]), |t| {
                    if !surface.point_triangle_adjacent(n, t) {
                        found.push((n, t));
                    }
                });
                found
            })
            .collect(),
        edge_edge: edge_boxes
            .par_iter()
            .enumerate()
            .flat_map_iter(|(a, bbox)| {
                let mut found = Vec::new();
                edges.query(bbox, |b| {
                    if a < b && !surface.edges_adjacent(a, b) {
                        found.push((a, b));
                    }
                });
                found
            })
            .collect(),
    };
    out.point_triangle.sort_unstable();
    out.edge_edge.sort_unstable();
    Ok(out)
}

/// The pairs of triangles of `surface` whose boxes at `positions` overlap (the candidates of
/// the intersection check; adjacent ones included), (a, b) with a < b, sorted.
pub fn triangle_pairs(
    surface: &Surface,
    positions: &[Vector3<f64>],
) -> Result<Vec<(usize, usize)>> {
    surface.check_positions("triangle pairs", positions)?;
    let boxes: Vec<Aabb> = surface
        .triangles()
        .iter()
        .map(|t| Aabb::of_points(t.iter().map(|&n| &positions[n])))
        .collect();
    let bvh = Bvh::new(boxes.clone());
    let mut pairs = Vec::new();
    for (a, bbox) in boxes.iter().enumerate() {
        bvh.query(bbox, |b| {
            if a < b {
                pairs.push((a, b));
            }
        });
    }
    pairs.sort_unstable();
    Ok(pairs)
}
