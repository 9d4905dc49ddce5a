//! Static cases: patch tests, manufactured solution, cantilever convergence, cross-check with an
//! independent code, and the model-choice guidance.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::time::Instant;

use nalgebra::{Matrix3, Vector3};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::fe::element::Vector12;
use tetfem::model::ModelKind;
use tetfem::post::convergence::{Level, Study};
use tetfem::post::error_norms::{energy_error, l2_error};
use tetfem::{BoxSplit, Constraints, Loads, Material, Result, TetMesh, solve_static};
use tetfem_fixtures::cantilever::Cantilever;
use tetfem_validation::chart::{Chart, Mark, Series};

use super::{Check, Context, Section, Skipped, chart_link, relative};

/// Tip deflections of the peer benchmark (`Cantilever::peer_benchmark`, cells n × n/10 × n/10)
/// from scikit-fem + CHOLMOD, identical for SuperLU, MFEM and NGSolve to ≤ 2.5e-9 relative:
/// `shared/peers/RESULTS.md`, table "P1 tip deflection vs mesh", printed to 10 digits.
const PEER_TIPS: [(usize, f64); 5] = [
    (10, -8.148605249e-03),
    (20, -1.872118396e-02),
    (40, -3.014193845e-02),
    (80, -3.673226398e-02),
    (160, -3.911340095e-02),
];

/// Bound on |tetfem − peers| / |peers| for the tips of [`PEER_TIPS`]: the same mesh and
/// discretization, so only round-off (the peers' own spread is ≤ 2.5e-9 at 160×16×16, 5.7e-10 at
/// 80×8×8) and the 10 printed digits (≤ 6e-11 relative) separate the answers.
const PEER_BOUND: f64 = 1e-8;

/// The fixed peer tip of an n × n/10 × n/10 cantilever, if RESULTS.md has it.
fn peer_tip(n: usize) -> Option<f64> {
    PEER_TIPS.iter().find(|(m, _)| *m == n).map(|(_, t)| *t)
}

/// Boundary nodes of a mesh (on any boundary face).
fn boundary_nodes(mesh: &TetMesh) -> Result<Vec<usize>> {
    let mut nodes: Vec<usize> = mesh
        .boundary_faces()?
        .iter()
        .flat_map(|f| f.nodes)
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    Ok(nodes)
}

/// The unit cube as 7 hexahedra around MacNeal & Harder's 8 interior points, each hex cut into
/// 24 tets through its centroid and its face centroids (conforming by construction: shared faces
/// share their centroid node).
fn macneal_harder_mesh() -> Result<TetMesh> {
    let inner = [
        [0.249, 0.342, 0.192],
        [0.826, 0.288, 0.288],
        [0.850, 0.649, 0.263],
        [0.273, 0.750, 0.230],
        [0.320, 0.186, 0.643],
        [0.677, 0.305, 0.683],
        [0.788, 0.693, 0.644],
        [0.165, 0.745, 0.702],
    ];
    let outer = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 1.0],
    ];
    let mut nodes: Vec<Vector3<f64>> = outer
        .iter()
        .chain(&inner)
        .map(|p| Vector3::new(p[0], p[1], p[2]))
        .collect();
    // Hex corners in the order (bottom 0-3 counter-clockwise, top 4-7); outer nodes 0-7, inner 8-15.
    let o = |i: usize| i;
    let n = |i: usize| 8 + i;
    let hexes: [[usize; 8]; 7] = [
        [n(0), n(1), n(2), n(3), n(4), n(5), n(6), n(7)],
        [o(0), o(1), o(2), o(3), n(0), n(1), n(2), n(3)],
        [n(4), n(5), n(6), n(7), o(4), o(5), o(6), o(7)],
        [o(0), o(1), n(1), n(0), o(4), o(5), n(5), n(4)],
        [n(3), n(2), o(2), o(3), n(7), n(6), o(6), o(7)],
        [o(0), n(0), n(3), o(3), o(4), n(4), n(7), o(7)],
        [n(1), o(1), o(2), n(2), n(5), o(5), o(6), n(6)],
    ];
    let faces = [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let mut face_centre = std::collections::HashMap::new();
    let mut tets = Vec::new();
    for hex in hexes {
        let centre = nodes.len();
        nodes.push(hex.iter().map(|&i| nodes[i]).sum::<Vector3<f64>>() / 8.0);
        for face in faces {
            let corners = face.map(|k| hex[k]);
            let mut key = corners;
            key.sort_unstable();
            let fc = *face_centre.entry(key).or_insert_with(|| {
                nodes.push(corners.iter().map(|&i| nodes[i]).sum::<Vector3<f64>>() / 4.0);
                nodes.len() - 1
            });
            for k in 0..4 {
                tets.push([corners[k], corners[(k + 1) % 4], fc, centre]);
            }
        }
    }
    TetMesh::new(nodes, tets)
}

/// Patch tests: linear fields reproduced on distorted meshes (both splits) and MacNeal–Harder's
/// 3D patch (E = 1e6, ν = 0.25, all strains 1e-3).
pub fn patch_tests(_context: &Context) -> Result<Section> {
    let mut checks = Vec::new();
    let mut body = String::new();
    let _ = writeln!(
        body,
        "| mesh | tets | max error / field scale |\n|---|---|---|"
    );
    let material = Material::new(1e6, 0.25, 1.0)?;
    // A general linear field on distorted box meshes.
    for split in [BoxSplit::Lecture6, BoxSplit::Five] {
        let base = TetMesh::box_grid(Vector3::zeros(), Vector3::repeat(1.0), [4, 4, 4], split)?;
        let (lo, hi) = base.bounding_box();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut random = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let nodes = base
            .nodes()
            .iter()
            .map(|p| {
                let interior = (0..3).all(|a| p[a] > lo[a] + 1e-9 && p[a] < hi[a] - 1e-9);
                if interior {
                    p + Vector3::new(random(), random(), random()) * 0.1
                } else {
                    *p
                }
            })
            .collect();
        let mesh = base.with_nodes(nodes)?;
        let a = Matrix3::new(1.0, 0.3, -0.2, 0.5, -0.7, 0.1, 0.2, 0.4, 0.6) * 1e-3;
        let b = Vector3::new(1e-4, -2e-4, 3e-4);
        let error = patch_error(&mesh, &material, |p| a * p + b)?;
        let _ = writeln!(
            body,
            "| distorted 4×4×4 box, {split:?} | {} | {error:.2e} |",
            mesh.tet_count()
        );
        checks.push(Check {
            name: format!("linear field, distorted {split:?} mesh"),
            bound: "≤ 1e-10".into(),
            measured: format!("{error:.1e}"),
            pass: error <= 1e-10,
        });
    }
    let mesh = macneal_harder_mesh()?;
    let field = |p: &Vector3<f64>| {
        Vector3::new(
            2.0 * p.x + p.y + p.z,
            p.x + 2.0 * p.y + p.z,
            p.x + p.y + 2.0 * p.z,
        ) * 0.5e-3
    };
    let error = patch_error(&mesh, &material, field)?;
    let solution = {
        let mut constraints = Constraints::new(&mesh);
        for n in boundary_nodes(&mesh)? {
            constraints.prescribe(n, field(&mesh.nodes()[n]))?;
        }
        solve_static(&mesh, &material, &constraints, &Loads::new(&mesh))?
    };
    let mut strain_error: f64 = 0.0;
    for t in 0..mesh.tet_count() {
        let nodes = mesh.tets()[t];
        let u = Vector12::from_fn(|i, _| solution.displacement[3 * nodes[i / 3] + i % 3]);
        let strain = mesh.element(t)?.strain(&u);
        // ε_xx = ε_yy = ε_zz = 1e-3 and tensor shear 0.5e-3 (engineering γ = 1e-3).
        let exact = Matrix3::new(1.0, 0.5, 0.5, 0.5, 1.0, 0.5, 0.5, 0.5, 1.0) * 1e-3;
        strain_error = strain_error.max((strain - exact).amax() / 1e-3);
    }
    let _ = writeln!(
        body,
        "| MacNeal–Harder unit cube (7 hexes around the 8 standard interior points, 24 tets each) | {} | {error:.2e} |\n\n\
         MacNeal–Harder: prescribed u = 1e-3·(2x+y+z)/2, v = 1e-3·(x+2y+z)/2, w = 1e-3·(x+y+2z)/2 on the boundary; every \
         strain component (ε_xx, ε_yy, ε_zz, γ_xy, γ_yz, γ_zx) must be 1e-3 in every tet: largest deviation {strain_error:.2e} of 1e-3.",
        mesh.tet_count()
    );
    checks.push(Check {
        name: "MacNeal–Harder strains = 1e-3".into(),
        bound: "≤ 1e-10 relative".into(),
        measured: format!("{strain_error:.1e}"),
        pass: strain_error <= 1e-10 && error <= 1e-10,
    });
    Ok(Section {
        title: "Patch tests".into(),
        body,
        checks,
    })
}

fn patch_error(
    mesh: &TetMesh,
    material: &Material,
    field: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Result<f64> {
    let mut constraints = Constraints::new(mesh);
    for n in boundary_nodes(mesh)? {
        constraints.prescribe(n, field(&mesh.nodes()[n]))?;
    }
    let solution = solve_static(mesh, material, &constraints, &Loads::new(mesh))?;
    let scale = mesh
        .nodes()
        .iter()
        .map(|p| field(p).amax())
        .fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    for (n, p) in mesh.nodes().iter().enumerate() {
        let u = Vector3::new(
            solution.displacement[3 * n],
            solution.displacement[3 * n + 1],
            solution.displacement[3 * n + 2],
        );
        worst = worst.max((u - field(p)).amax());
    }
    Ok(worst / scale)
}

/// u = α·φ·(1,1,1) + A·x + c with φ = sin πx sin πy sin πz on the unit cube.
pub fn manufactured(context: &Context) -> Result<Section> {
    let material = Material::new(1e3, 0.3, 1.0)?;
    let alpha = 1e-3;
    let a = Matrix3::new(2e-4, -1e-4, 0.5e-4, 0.3e-4, -2e-4, 1e-4, 0.0, 1.5e-4, 1e-4);
    let c = Vector3::new(1e-4, -2e-4, 0.5e-4);
    let trig = |p: &Vector3<f64>| {
        (
            [(PI * p.x).sin(), (PI * p.y).sin(), (PI * p.z).sin()],
            [(PI * p.x).cos(), (PI * p.y).cos(), (PI * p.z).cos()],
        )
    };
    let exact = |p: &Vector3<f64>| {
        let (s, _) = trig(p);
        Vector3::repeat(alpha * s[0] * s[1] * s[2]) + a * p + c
    };
    let gradient = |p: &Vector3<f64>| {
        let (s, co) = trig(p);
        let g = Vector3::new(
            co[0] * s[1] * s[2],
            s[0] * co[1] * s[2],
            s[0] * s[1] * co[2],
        ) * PI;
        Matrix3::from_fn(|_, j| alpha * g[j]) + a
    };
    let body_force = |p: &Vector3<f64>| {
        let (s, co) = trig(p);
        let phi = s[0] * s[1] * s[2];
        let pi2 = PI * PI;
        let h = Matrix3::new(
            -pi2 * phi,
            pi2 * co[0] * co[1] * s[2],
            pi2 * co[0] * s[1] * co[2],
            pi2 * co[0] * co[1] * s[2],
            -pi2 * phi,
            pi2 * s[0] * co[1] * co[2],
            pi2 * co[0] * s[1] * co[2],
            pi2 * s[0] * co[1] * co[2],
            -pi2 * phi,
        );
        let (lambda, mu) = (material.lame_lambda(), material.shear_modulus());
        -(Vector3::repeat(mu * -3.0 * pi2 * phi) + h * Vector3::repeat(lambda + mu)) * alpha
    };
    let sizes: &[usize] = if context.quick {
        &[3, 6, 12, 18]
    } else {
        &[4, 8, 16, 32]
    };
    let mut l2 = Vec::new();
    let mut energy = Vec::new();
    let mut body = String::from(
        "| n | h | DOFs | L2 error | energy error | wall time [s] |\n|---|---|---|---|---|---|\n",
    );
    for &n in sizes {
        let clock = Instant::now();
        let mesh = TetMesh::box_grid(
            Vector3::zeros(),
            Vector3::repeat(1.0),
            [n; 3],
            BoxSplit::Lecture6,
        )?;
        let mut constraints = Constraints::new(&mesh);
        for node in mesh.nodes_where(|p| (0..3).any(|k| p[k] == 0.0 || p[k] == 1.0)) {
            constraints.prescribe(node, exact(&mesh.nodes()[node]))?;
        }
        let mut loads = Loads::new(&mesh);
        loads.add_body_force_field(&mesh, body_force)?;
        let solution = solve_static(&mesh, &material, &constraints, &loads)?;
        let seconds = clock.elapsed().as_secs_f64();
        let h = 1.0 / n as f64;
        let e_l2 = l2_error(&mesh, &solution.displacement, exact)?;
        let e_en = energy_error(&mesh, &material, &solution.displacement, gradient)?;
        let _ = writeln!(
            body,
            "| {n} | {h:.4} | {} | {e_l2:.4e} | {e_en:.4e} | {seconds:.2} |",
            mesh.dof_count()
        );
        l2.push(Level {
            h,
            dofs: mesh.dof_count(),
            error: e_l2,
            seconds,
        });
        energy.push(Level {
            h,
            dofs: mesh.dof_count(),
            error: e_en,
            seconds,
        });
    }
    let (l2, energy) = (Study::new(l2)?, Study::new(energy)?);
    let (p2, p1) = (l2.fitted_order()?, energy.fitted_order()?);
    let _ = writeln!(
        body,
        "\nObserved orders between levels: L2 {:?}, energy {:?}; least-squares fits: L2 {p2:.3}, energy {p1:.3}.\n",
        l2.observed_orders()
            .iter()
            .map(|o| format!("{o:.3}"))
            .collect::<Vec<_>>(),
        energy
            .observed_orders()
            .iter()
            .map(|o| format!("{o:.3}"))
            .collect::<Vec<_>>()
    );
    body.push_str(&manufactured_chart(context, &l2, &energy)?);
    Ok(Section {
        title: "Manufactured solution".into(),
        body,
        checks: vec![
            Check {
                name: "L2 order".into(),
                bound: "2 ± 0.15".into(),
                measured: format!("{p2:.3}"),
                pass: (p2 - 2.0).abs() <= 0.15,
            },
            Check {
                name: "energy order".into(),
                bound: "1 ± 0.15".into(),
                measured: format!("{p1:.3}"),
                pass: (p1 - 1.0).abs() <= 0.15,
            },
        ],
    })
}

/// The manufactured solution's convergence chart (L2 and energy-norm errors against h, with
/// slopes 2 and 1 from the first level), as the report's link to it.
fn manufactured_chart(context: &Context, l2: &Study, energy: &Study) -> Result<String> {
    let reference = |study: &Study, order: f64| {
        let first = study.levels[0];
        study
            .levels
            .iter()
            .map(|l| (l.h, first.error * (l.h / first.h).powf(order)))
            .collect()
    };
    let chart = Chart {
        title: "Manufactured solution on the unit cube".into(),
        x_label: "mesh size h".into(),
        y_label: "error".into(),
        log_x: true,
        log_y: true,
        series: vec![
            Series::new(
                "L2 error of u",
                l2.levels.iter().map(|l| (l.h, l.error)).collect(),
                Mark::LinePoints,
            ),
            Series::new("slope 2", reference(l2, 2.0), Mark::Dashed),
            Series::new(
                "energy-norm error",
                energy.levels.iter().map(|l| (l.h, l.error)).collect(),
                Mark::LinePoints,
            ),
            Series::new("slope 1", reference(energy, 1.0), Mark::Dashed),
        ],
    };
    chart_link(context, &chart, "manufactured.png")
}

/// The cantilever against Timoshenko, with its observed order and the honest bending error.
pub fn cantilever(context: &Context) -> Result<Section> {
    // Quick mode stops at 80×8×8 (19 683 DOFs, under a second); 160×16×16 (139 587 DOFs)
    // takes several seconds of factorization and runs in the full suite only.
    let sizes: &[usize] = if context.quick {
        &[10, 20, 40, 80]
    } else {
        &[10, 20, 40, 80, 160]
    };
    let mut body = String::from(
        "| cells | DOFs | tip deflection | Timoshenko | error | peers (RESULTS.md) | difference | wall time [s] |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut levels = Vec::new();
    let mut values = Vec::new();
    let mut monotone = true;
    let mut checks = Vec::new();
    for &n in sizes {
        let problem = Cantilever::peer_benchmark([n, n / 10, n / 10]);
        let clock = Instant::now();
        let solved = problem.solve()?;
        let seconds = clock.elapsed().as_secs_f64();
        let (_, timoshenko) = problem.beam_theory_tip();
        let error = relative(solved.tip_deflection, timoshenko);
        if let Some(last) = levels.last() {
            let last: &Level = last;
            monotone &= error < last.error;
        }
        let peer = peer_tip(n);
        let difference = peer.map(|p| relative(solved.tip_deflection, p));
        let _ = writeln!(
            body,
            "| {n}×{}×{} | {} | {:.9e} | {timoshenko:.6e} | {:.2}% | {} | {} | {seconds:.2} |",
            n / 10,
            n / 10,
            solved.mesh.dof_count(),
            solved.tip_deflection,
            100.0 * error,
            peer.map_or("–".into(), |p| format!("{p:.9e}")),
            difference.map_or("–".into(), |d| format!("{d:.1e}"))
        );
        // The error against Timoshenko is the discretization's own (bending lock), with no bound
        // from theory that is tighter than "falls"; what pins it is the same mesh in the
        // independent codes.
        if let Some(d) = difference {
            checks.push(Check {
                name: format!("{n}×{}×{} tip = peers' tip", n / 10, n / 10),
                bound: format!("≤ {PEER_BOUND:.0e} relative"),
                measured: format!("{d:.1e}"),
                pass: d <= PEER_BOUND,
            });
        }
        levels.push(Level {
            h: 1.0 / (n / 10) as f64,
            dofs: solved.mesh.dof_count(),
            error,
            seconds,
        });
        values.push(solved.tip_deflection);
    }
    let study = Study::new(levels)?;
    let order = study.fitted_order()?;
    let _ = writeln!(
        body,
        "\nLinear tets lock in bending: the error falls monotonically but slowly (observed orders {:?}, fit {order:.2} in h). \
         Three-level Richardson extrapolation of the finest tips: {}.\n",
        study
            .observed_orders()
            .iter()
            .map(|o| format!("{o:.2}"))
            .collect::<Vec<_>>(),
        match tetfem::post::convergence::richardson(
            values[values.len() - 3],
            values[values.len() - 2],
            values[values.len() - 1],
            2.0
        ) {
            Ok(r) => format!(
                "{:.6e} (order {:.2}; Timoshenko {:.6e})",
                r.value,
                r.order,
                Cantilever::peer_benchmark([10, 1, 1]).beam_theory_tip().1
            ),
            Err(e) => format!("not in the asymptotic range ({e})"),
        }
    );
    let chart = Chart {
        title: "Cantilever tip error vs Timoshenko (linear tets)".into(),
        x_label: "degrees of freedom".into(),
        y_label: "relative tip error".into(),
        log_x: true,
        log_y: true,
        series: vec![Series::new(
            "tetfem P1, lecture split",
            study
                .levels
                .iter()
                .map(|l| (l.dofs as f64, l.error))
                .collect(),
            Mark::LinePoints,
        )],
    };
    body.push_str(&chart_link(context, &chart, "cantilever.png")?);
    checks.insert(
        0,
        Check {
            name: "error falls monotonically".into(),
            bound: "monotone".into(),
            measured: format!("{monotone}"),
            pass: monotone,
        },
    );
    Ok(Section {
        title: "Cantilever vs Timoshenko".into(),
        body,
        checks,
    })
}

/// The same discretization solved live by scikit-fem (the peers harness) must give the same
/// tips. Without the harness (CI) its checks are reported as skipped; the fixed peer values of
/// `RESULTS.md` are checked in the cantilever case either way.
pub fn cross_check(_context: &Context) -> Result<(Section, Vec<Skipped>)> {
    let python = std::env::var("TETFEM_PEERS_PYTHON")
        .unwrap_or_else(|_| "/work/peers-venv/bin/python".into());
    let peers = std::env::var("TETFEM_PEERS").unwrap_or_else(|_| "../shared/peers".into());
    if !std::path::Path::new(&python).exists()
        || !std::path::Path::new(&peers)
            .join("cantilever_static.py")
            .exists()
    {
        let reason = format!(
            "peers harness not installed (looked for {python} and {peers}/cantilever_static.py)"
        );
        let skipped = [10usize, 20, 40]
            .iter()
            .map(|n| Skipped {
                name: format!("{n}×{}×{} tip, live scikit-fem", n / 10, n / 10),
                reason: reason.clone(),
            })
            .collect();
        return Ok((
            Section {
                title: "Cross-check with scikit-fem".into(),
                body: format!(
                    "Skipped: {reason}; run validation/setup_peers.sh. The peers' recorded tips (RESULTS.md) are \
                     checked in the cantilever case.\n"
                ),
                checks: vec![],
            },
            skipped,
        ));
    }
    let mut body = String::from(
        "| mesh | tetfem | scikit-fem + CHOLMOD | relative difference |\n|---|---|---|---|\n",
    );
    let mut checks = Vec::new();
    for n in [10usize, 20, 40] {
        let file =
            std::env::temp_dir().join(format!("tetfem-peer-{n}-{}.json", std::process::id()));
        let status = std::process::Command::new(&python)
            .current_dir(&peers)
            .args([
                "cantilever_static.py",
                "--nx",
                &n.to_string(),
                "--ny",
                &(n / 10).to_string(),
                "--nz",
                &(n / 10).to_string(),
                "--solver",
                "cholmod",
                "--wait-idle",
                "0",
                "--json",
            ])
            .arg(&file)
            .output();
        let peer = status
            .ok()
            .and_then(|_| std::fs::read_to_string(&file).ok())
            .and_then(|t| {
                let key = "\"tip\": ";
                let start = t.find(key)? + key.len();
                t[start..]
                    .split([',', '}'])
                    .next()?
                    .trim()
                    .parse::<f64>()
                    .ok()
            });
        let _ = std::fs::remove_file(&file);
        let ours = Cantilever::peer_benchmark([n, n / 10, n / 10])
            .solve()?
            .tip_deflection;
        match peer {
            Some(p) => {
                let d = relative(ours, p);
                let _ = writeln!(
                    body,
                    "| {n}×{}×{} | {ours:.12e} | {p:.12e} | {d:.1e} |",
                    n / 10,
                    n / 10
                );
                checks.push(Check {
                    name: format!("{n}×{}×{} tip, live scikit-fem", n / 10, n / 10),
                    bound: format!("≤ {PEER_BOUND:.0e}"),
                    measured: format!("{d:.1e}"),
                    pass: d <= PEER_BOUND,
                });
            }
            None => {
                let _ = writeln!(
                    body,
                    "| {n}×{}×{} | {ours:.12e} | (peer run failed) | – |",
                    n / 10,
                    n / 10
                );
                checks.push(Check {
                    name: format!("{n}×{}×{} tip, live scikit-fem", n / 10, n / 10),
                    bound: "peer runs".into(),
                    measured: "peer failed".into(),
                    pass: false,
                });
            }
        }
    }
    Ok((
        Section {
            title: "Cross-check with scikit-fem".into(),
            body,
            checks,
        },
        vec![],
    ))
}

/// The findings under the model-choice table: where the linear model's tip-vector error
/// crosses 1 % and 10 % (`threshold`) and its vertical deflection 1 % (`z_threshold`, tip
/// rotations in degrees), and the corotational model's largest error up to 60°.
fn write_model_choice_findings(
    body: &mut String,
    threshold: [Option<f64>; 2],
    z_threshold: Option<f64>,
    corot_worst: f64,
    dofs: usize,
) {
    let describe = |t: Option<f64>| {
        t.map_or("not reached in the sweep".to_string(), |r| {
            format!("at a tip rotation of about {r:.1}°")
        })
    };
    let _ = writeln!(
        body,
        "\nFrom these data (tip-vector error, the stricter measure: the vertical deflection alone stays accurate longer \
         because it misses the tip's swing toward the clamp): the linear model's error exceeds 1 % {} and 10 % {}; below that a scene needs no more than \
         the linear model. The vertical deflection alone passes 1 % {}. The corotational model stays within {:.3} % of \
         Neo-Hookean up to 60° of tip rotation (both are rotation-invariant; they differ only by the material law at finite \
         strain). Costs are per Newton iteration of the whole solve on this {}-DOF mesh (assembly of the tangent + numeric \
         refactorization + solve).\n",
        describe(threshold[0]),
        describe(threshold[1]),
        describe(z_threshold),
        100.0 * corot_worst,
        dofs
    );
}

/// The tip displacement of `kind` (built on `base`'s material) under loads `l`, solved by
/// Newton with `options`, and the solve's wall time per Newton iteration (ms).
fn timed_solve(
    mesh: &TetMesh,
    base: &Cantilever,
    kind: ModelKind,
    constraints: &Constraints,
    l: &Loads,
    options: NewtonOptions,
) -> Result<(Vec<f64>, f64)> {
    let model = kind.build(&base.material);
    let clock = Instant::now();
    let report = solve_nonlinear_static(mesh, model.as_ref(), constraints, l, options)?;
    let per_iteration = clock.elapsed().as_secs_f64() * 1e3 / report.iterations.max(1) as f64;
    Ok((report.displacement, per_iteration))
}

/// The rotation (degrees) at which an error crosses `level` between two points (rotation,
/// error) that bracket it, interpolated linearly in log(error).
fn log_crossing((r0, e0): (f64, f64), (r1, e1): (f64, f64), level: f64) -> f64 {
    let t = (level.ln() - e0.max(1e-16).ln()) / (e1.ln() - e0.max(1e-16).ln());
    r0 + t * (r1 - r0)
}

/// Linear vs corotational vs Neo-Hookean as the load grows, against Neo-Hookean as reference.
pub fn model_choice(context: &Context) -> Result<Section> {
    let cells = if context.quick {
        [10, 2, 2]
    } else {
        [20, 2, 2]
    };
    let base = Cantilever::peer_benchmark(cells);
    let mesh = base.mesh()?;
    let constraints = base.constraints(&mesh)?;
    let loads_at = |p: f64| {
        Cantilever {
            end_load: p,
            ..base
        }
        .loads(&mesh)
    };
    let tip = |u: &[f64]| base.tip_deflection(&mesh, u);
    let tip_nodes = base.tip_nodes(&mesh);
    let tip_vector = |u: &[f64]| {
        tip_nodes
            .iter()
            .map(|&n| nalgebra::Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]))
            .sum::<nalgebra::Vector3<f64>>()
            / tip_nodes.len() as f64
    };
    let options = NewtonOptions {
        load_steps: 4,
        ..NewtonOptions::default()
    };
    // The same loads in both modes (the whole sweep takes under a second even on the full
    // mesh): dense enough around the 1 % and 10 % crossings that interpolating between two
    // loads moves a crossing by a small fraction of its window below.
    let loads = [
        1.0, 5.0, 10.0, 15.0, 20.0, 40.0, 60.0, 80.0, 100.0, 150.0, 300.0, 600.0,
    ];
    let mut body = String::from(
        "| end load | NH tip (reference) | tip rotation | linear error, tip z | linear error, tip vector | corotational error, tip vector | cost per Newton iteration (lin / corot / NH) [ms] |\n|---|---|---|---|---|---|---|\n",
    );
    let mut linear_series = Vec::new();
    let mut corot_series = Vec::new();
    let mut threshold = [None, None];
    let mut z_threshold = None;
    let mut previous_z: Option<(f64, f64)> = None;
    // Largest corotational error over the loads whose tip rotation is at most 60°.
    let mut corot_worst: f64 = 0.0;
    for p in loads {
        let l = loads_at(p)?;
        let mut results = Vec::new();
        for kind in [
            ModelKind::Linear,
            ModelKind::Corotational,
            ModelKind::NeoHookean,
        ] {
            let (displacement, per_iteration) =
                timed_solve(&mesh, &base, kind, &constraints, &l, options)?;
            results.push((tip(&displacement)?, per_iteration, displacement));
        }
        let reference = results[2].0;
        let rotation = {
            let u = &results[2].2;
            let n = |ix: usize| tetfem::mesh::box_node_index(cells, ix, 0, 0);
            let (a, b) = (n(cells[0] - 1), n(cells[0]));
            let d = |k: usize, n: usize| mesh.nodes()[n][k] + u[3 * n + k];
            (-(d(2, b) - d(2, a))).atan2(d(0, b) - d(0, a)).to_degrees()
        };
        let e_z = relative(results[0].0, reference);
        // The tip vector catches what the vertical deflection alone misses: under large rotation
        // the tip also swings back toward the clamp, which the linear model leaves out entirely.
        let reference_vector = tip_vector(&results[2].2);
        let vector_error = |k: usize| {
            (tip_vector(&results[k].2) - reference_vector).norm() / reference_vector.norm()
        };
        let (e_lin, e_cor) = (vector_error(0), vector_error(1));
        let _ = writeln!(
            body,
            "| {p} | {reference:.5e} | {rotation:.1}° | {:.2}% | {:.2}% | {:.3}% | {:.2} / {:.2} / {:.2} |",
            100.0 * e_z,
            100.0 * e_lin,
            100.0 * e_cor,
            results[0].1,
            results[1].1,
            results[2].1
        );
        if rotation <= 60.0 {
            corot_worst = corot_worst.max(e_cor);
        }
        if let Some((r_prev, e_prev)) = previous_z
            && z_threshold.is_none()
            && e_z > 0.01
            && e_prev <= 0.01
        {
            z_threshold = Some(log_crossing((r_prev, e_prev), (rotation, e_z), 0.01));
        }
        previous_z = Some((rotation, e_z));
        linear_series.push((rotation.max(1e-3), e_lin));
        corot_series.push((rotation.max(1e-3), e_cor.max(1e-12)));
        // Where the linear error crosses 1 % and 10 %: interpolated in log(error) between the
        // bracketing loads.
        if let Some(&(r_prev, e_prev)) = linear_series.iter().rev().nth(1) {
            for (k, level) in [0.01f64, 0.1].iter().enumerate() {
                if threshold[k].is_none() && e_lin > *level && e_prev <= *level {
                    threshold[k] = Some(log_crossing((r_prev, e_prev), (rotation, e_lin), *level));
                }
            }
        }
    }
    write_model_choice_findings(
        &mut body,
        threshold,
        z_threshold,
        corot_worst,
        mesh.dof_count(),
    );
    let chart = Chart {
        title: "Model choice: tip error against Neo-Hookean as the load grows".into(),
        x_label: "tip rotation [degrees]".into(),
        y_label: "relative tip error".into(),
        log_x: true,
        log_y: true,
        series: vec![
            Series::new(
                "linear (Cauchy strain), tip vector",
                linear_series,
                Mark::LinePoints,
            ),
            Series::new("corotational, tip vector", corot_series, Mark::LinePoints),
        ],
    };
    body.push_str(&chart_link(context, &chart, "model_choice.png")?);
    Ok(Section {
        title: "Model choice (linear, corotational, Neo-Hookean)".into(),
        body,
        checks: vec![
            crossing_check("1 %", threshold[0], [1.0, 2.0]),
            crossing_check("10 %", threshold[1], [12.0, 16.0]),
            Check {
                name: "corotational vs Neo-Hookean, tip vector, rotations ≤ 60°".into(),
                // The book's claim (`docs/src/large-deformation.md`). Both models are rotation-invariant and share the
                // small-strain limit; they differ by the material law at finite strain, which
                // at these strains (≲ 1 %) is of the order of the strain itself.
                bound: "≤ 0.3 %".into(),
                measured: format!("{:.3} %", 100.0 * corot_worst),
                pass: corot_worst <= 0.003,
            },
        ],
    })
}

/// The tip rotation at which the linear model's tip-vector error crosses `level` must lie in
/// `window` (degrees).
///
/// Why these windows: the linear model misses the tip's swing back toward the clamp. For an
/// Euler–Bernoulli cantilever under an end load the slope is w′ = θ·(2ξ − ξ²) (θ the tip
/// rotation, ξ = x/L), so inextensibility shortens the tip by ½∫(w′)² dx = (4/15)·θ²·L, while the
/// tip deflects by (2/3)·L·θ: a relative error of (2/5)·θ, i.e. 1 % at θ = 0.025 rad = 1.43° and
/// 10 % at 0.25 rad = 14.3°. The windows [1°, 2°] and [12°, 16°] hold that first-order prediction
/// with room for what it leaves out: the vertical error (second order in θ), shear and the
/// coarse mesh's bending lock (which changes deflection and rotation alike, nearly cancelling in
/// their ratio), and the log-linear interpolation between two loads of the sweep.
fn crossing_check(level: &str, crossing: Option<f64>, window: [f64; 2]) -> Check {
    Check {
        name: format!("linear model's tip-vector error crosses {level}"),
        bound: format!("at a tip rotation in [{}°, {}°]", window[0], window[1]),
        measured: crossing.map_or("not reached in the sweep".into(), |r| format!("{r:.2}°")),
        pass: crossing.is_some_and(|r| (window[0]..=window[1]).contains(&r)),
    }
}
