//! Memory before allocating, for the mixed analyses: the linear dynamic and modal operator
//! (`MixedOperator`, shared by `MixedTransient` and `lowest_mixed_modes`, on 10-node
//! Taylor–Hood and 4-node stabilized P1–P1 tets) and the Neo-Hookean
//! Newton solve check the size a mesh will need before assembling anything, and a run too large
//! for the process's address-space limit is an `Error::InsufficientMemory` naming the size, not
//! an allocator abort. The limit is set on a child process of this test binary (util-linux
//! `prlimit --pid`), so no other test runs under it.

use std::process::Command;

use nalgebra::Vector3;
use tetfem::analysis::dynamics::{Method, Rayleigh};
use tetfem::analysis::mixed_dynamics::MixedTransient;
use tetfem::analysis::mixed_modal::lowest_mixed_modes;
use tetfem::analysis::nonlinear::NewtonOptions;
use tetfem::base::memory::{dense_kernel_reservation, status_bytes};
use tetfem::{
    BoxSplit, Constraints, Loads, Material, Tet10, TetMesh, solve_static_mixed_nonlinear,
};

const CHILD: &str = "TETFEM_MIXED_MEMORY_CHILD";

/// Room the child leaves itself above what it maps already (and the dense kernels' reservation,
/// which the factorizing paths keep back): enough to build the meshes (the large one holds
/// 8 MB), far below the large mesh's estimates (printed: 4.0 GB for the dynamic or modal
/// operator, 3.1 GB for Newton's solve).
const ROOM: u64 = 600_000_000;

/// A unit box of `cells`³ cells of the 5-tet split, on 10-node tets, clamped at x = 0.
fn clamped_box(cells: usize) -> (TetMesh<Tet10>, Constraints) {
    let linear = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [cells; 3],
        BoxSplit::Five,
    )
    .unwrap();
    let mesh = TetMesh::<Tet10>::from_linear(&linear).unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    (mesh, constraints)
}

/// The linear dynamic and modal runs of the 4-node stabilized P1–P1 element on a unit box of
/// `cells`³ cells of the 5-tet split clamped at x = 0, named: Ok or its error.
fn p1p1_runs(cells: usize) -> Vec<(&'static str, Result<(), tetfem::Error>)> {
    let mesh = TetMesh::box_grid(
        Vector3::zeros(),
        Vector3::new(1.0, 1.0, 1.0),
        [cells; 3],
        BoxSplit::Five,
    )
    .unwrap();
    let mut constraints = Constraints::new(&mesh);
    constraints
        .fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9))
        .unwrap();
    let material = Material::new(1e6, 0.499, 1000.0).unwrap();
    let modal = lowest_mixed_modes(&mesh, &material, &constraints, 1).map(|_| ());
    let dynamic = MixedTransient::new(
        &mesh,
        &material,
        &constraints,
        &Loads::new(&mesh),
        (Method::Newmark, 1e-3, Rayleigh::default()),
    )
    .map(|_| ());
    vec![("p1p1-modal", modal), ("p1p1-dynamic", dynamic)]
}

/// Each mixed run on `cells`³ cells, named: Ok or its error.
fn runs(cells: usize) -> Vec<(&'static str, Result<(), tetfem::Error>)> {
    let (mesh, constraints) = clamped_box(cells);
    let material = Material::new(1e6, 0.499, 1000.0).unwrap();
    let loads = Loads::new(&mesh);
    let modal = lowest_mixed_modes(&mesh, &material, &constraints, 1).map(|_| ());
    let dynamic = MixedTransient::new(
        &mesh,
        &material,
        &constraints,
        &loads,
        (Method::Newmark, 1e-3, Rayleigh::default()),
    )
    .map(|_| ());
    let options = NewtonOptions {
        load_steps: 1,
        ..NewtonOptions::default()
    };
    let newton =
        solve_static_mixed_nonlinear(&mesh, &material, &constraints, &loads, options).map(|_| ());
    vec![("modal", modal), ("dynamic", dynamic), ("newton", newton)]
}

#[test]
#[ignore = "run by too_large_mixed_runs_stop_before_allocating in a process of its own"]
fn child_mixed_runs_under_a_limit() {
    if std::env::var(CHILD).is_err() {
        return;
    }
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let held = status_bytes(&status, "VmSize:").unwrap();
    let limit = held + dense_kernel_reservation().bytes + ROOM;
    let pid = std::process::id().to_string();
    let set = Command::new("prlimit")
        .args(["--pid", &pid, &format!("--as={limit}")])
        .status()
        .expect("prlimit (util-linux) runs");
    assert!(set.success(), "prlimit --pid failed: {set:?}");
    // 24³ cells: 69 120 tets, 103 825 nodes, estimates of 3–4 GB; 2³: 40 tets, well under 1 MB.
    // The 4-node element: 48³ cells, 552 960 tets and 117 649 nodes.
    for (cells, verdict, p1p1) in [(24, "LARGE", 48), (2, "SMALL", 2)] {
        for (name, result) in runs(cells).into_iter().chain(p1p1_runs(p1p1)) {
            match result {
                Ok(()) => println!("{verdict} {name} ok"),
                Err(error) => println!("{verdict} {name} error {error}"),
            }
        }
    }
}

#[test]
fn too_large_mixed_runs_stop_before_allocating() {
    // The test's name within this binary: its module path without the crate's name.
    let module = module_path!().split_once("::").map_or("", |(_, m)| m);
    let test = format!("{module}::child_mixed_runs_under_a_limit");
    let output = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            &test,
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, "1")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    println!("{stdout}");
    // An allocation beyond the limit would abort the child (a signal, no exit code).
    assert!(
        output.status.success(),
        "{:?}\n{stdout}{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    for name in ["modal", "dynamic", "newton", "p1p1-modal", "p1p1-dynamic"] {
        // The harness prints its "test … ... " prefix on the first line: from the key on.
        let line = |verdict: &str| {
            let key = format!("{verdict} {name} ");
            stdout
                .lines()
                .find_map(|l| l.find(&key).map(|at| l[at..].to_string()))
                .unwrap_or_else(|| panic!("no {key}line in\n{stdout}"))
        };
        // The large mesh: refused, naming the size needed and the bound.
        let large = line("LARGE");
        for word in ["not enough memory", "mixed", "needs", "RLIMIT_AS"] {
            assert!(large.contains(word), "no '{word}' in {large}");
        }
        // The way out it names is one a mixed run has: a coarser mesh, not the iterative
        // solver (a mixed solve always factors its saddle point).
        assert!(large.contains("coarser mesh"), "no way out in {large}");
        assert!(
            !large.contains("linear_solver"),
            "a way out mixed runs lack in {large}"
        );
        // The same limit does not refuse a run that fits.
        assert_eq!(line("SMALL"), format!("SMALL {name} ok"));
    }
}
