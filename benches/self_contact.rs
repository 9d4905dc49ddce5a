//! The broad phase of body–body contact (issue 36) at three surface sizes, each 4× the last:
//! two blocks of c³ cells (c = 8, 16, 32: 1,536, 6,144 and 24,576 surface triangles) stacked
//! half a reach d̂ apart, the upper one turned about z so that its surface grid does not line
//! up with the lower one's. Timed: the hierarchy over the triangles alone (`bvh_build`), the
//! candidate pairs within d̂ (building the two
//! hierarchies and querying every vertex and edge), and the barrier's active pairs on top
//! (the narrow phase's exact distances). With n triangles a BVH costs n log n to build and
//! log n + k per query, so the time per triangle should grow like log n — read the ratios
//! between sizes from one run.
//!
//! `cargo bench --bench self_contact`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Rotation3, Vector3};
use tetfem::contact::surface::{Aabb, Bvh, Surface, SurfaceBarrier, candidates};
use tetfem::{BoxSplit, TetMesh};

/// Two 0.1 m blocks of `cells`³ cells, the upper one turned by 0.3 rad about z, `gap` above.
fn two_blocks(cells: usize, gap: f64) -> (Surface, Vec<Vector3<f64>>) {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::repeat(0.1),
        [cells; 3],
        BoxSplit::Lecture6,
    )
    .unwrap();
    let base = Surface::from_mesh(&mesh).unwrap();
    let n = mesh.node_count();
    let turn = Rotation3::from_euler_angles(0.0, 0.0, 0.3);
    let centre = Vector3::new(0.05, 0.05, 0.0);
    let mut positions = mesh.nodes().to_vec();
    positions.extend(
        mesh.nodes()
            .iter()
            .map(|x| turn * (x - centre) + centre + Vector3::new(0.0, 0.0, 0.1 + gap)),
    );
    let mut triangles = base.triangles().to_vec();
    triangles.extend(base.triangles().iter().map(|t| t.map(|k| k + n)));
    (
        Surface::from_triangles(triangles, &positions).unwrap(),
        positions,
    )
}

fn broad_phase(c: &mut Criterion) {
    let d_hat = 1e-3;
    let barrier = SurfaceBarrier::new(d_hat, 1.0).unwrap();
    let mut group = c.benchmark_group("self_contact");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for cells in [8, 16, 32] {
        let (surface, x) = two_blocks(cells, 0.5 * d_hat);
        let found = candidates(&surface, &x, None, d_hat).unwrap();
        let label = format!(
            "{} triangles, {} candidates",
            surface.triangles().len(),
            found.point_triangle.len() + found.edge_edge.len()
        );
        let boxes: Vec<Aabb> = surface
            .triangles()
            .iter()
            .map(|t| Aabb::of_points(t.iter().map(|&n| &x[n])).inflated(0.5 * d_hat))
            .collect();
        group.bench_function(BenchmarkId::new("bvh_build", &label), |b| {
            b.iter(|| black_box(Bvh::new(boxes.clone())))
        });
        group.bench_function(BenchmarkId::new("candidates", &label), |b| {
            b.iter(|| black_box(candidates(&surface, &x, None, d_hat).unwrap()))
        });
        group.bench_function(BenchmarkId::new("active_pairs", &label), |b| {
            b.iter(|| black_box(barrier.active_pairs(&surface, &x).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(benches, broad_phase);
criterion_main!(benches);
