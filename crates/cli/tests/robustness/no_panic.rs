//! Every public entry point, driven with hostile input under `catch_unwind`: wrong lengths,
//! out-of-range indices, NaN and infinities, empty sets, objects from another mesh, absurd
//! options. Each probe states its outcome: `err` names the `Error` variant it must return,
//! `ok` says the input is valid after all, `value` is for functions without a `Result` (they
//! must return at all). None may panic.
//!
//! The calls are collected and all run before the one assertion, so that a failure lists
//! every entry point that panicked or gave another outcome, not just the first.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};
use tetfem::analysis::dynamics::{
    BackwardEuler, DivergenceGuard, Energy, Integrator, IntegratorOptions, InternalForce,
    LinearSystem, Mass, MassKind, Method, NonlinearForce, Rayleigh, State, critical_time_step,
    element_critical_step,
};
use tetfem::analysis::modal::{lowest_modes, mass_inner_product};
use tetfem::analysis::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::analysis::statics::StaticSolver;
use tetfem::bc::constraints::{DofMap, ensure_held};
use tetfem::fe::assembly::{Assembler, lumped_mass, stiffness_matrix};
use tetfem::fe::element::{
    Matrix12, Tet, rest_shape_matrix, shape_quality, signed_volume, von_mises,
};
use tetfem::fe::quadrature::{integrate, shape_values, tet_rule};
use tetfem::fe::quality::tet_quality;
use tetfem::linalg::amg::{NearNullSpace, SmoothedAggregation};
use tetfem::linalg::iterative::{BlockJacobi, CgOptions, Preconditioner, conjugate_gradient};
use tetfem::linalg::linear_solver::{LinearMethod, LinearSolver, SolverOptions};
use tetfem::linalg::linsolve::{CholeskyOptions, SparseCholesky};
use tetfem::linalg::ordering::{inverse_permutation, nested_dissection};
use tetfem::linalg::sparse::CscMatrix;
use tetfem::mesh::io::{read_gmsh, read_mesh, read_tetgen, write_gmsh};
use tetfem::mesh::{BoundaryFace, BoxSplit};
use tetfem::model::{ModelKind, assemble, project_psd};
use tetfem::post::convergence::{Level, Study, fit_slope, richardson};
use tetfem::post::error_norms::{energy_error, l2_error};
use tetfem::post::output::fields::{
    cell_strain_energy_density, cell_stress, cell_von_mises, displacement_magnitude,
};
use tetfem::post::output::{
    CsvSeries, PvdCollection, VtuWriter, write_atomically, write_result_vtu,
};
use tetfem::{Constraints, Error, Loads, Material, TetMesh, solve_static};
use tetfem_cli::render::{Field, RenderOptions, auto_deformation_scale, render, viridis};
use tetfem_cli::scene::Scene;
use tetfem_fixtures::beam_theory::RectangularCantilever;
use tetfem_fixtures::cantilever::Cantilever;
use tetfem_validation::chart::{Chart, Mark, Series};

const NAN: f64 = f64::NAN;
const INF: f64 = f64::INFINITY;

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

/// The name of `error`'s variant, from a match on every variant (so that a renamed variant
/// breaks this test's build rather than its expectations).
fn variant(error: &Error) -> &'static str {
    match error {
        Error::EmptyMesh { .. } => "EmptyMesh",
        Error::NonFiniteCoordinate { .. } => "NonFiniteCoordinate",
        Error::NodeIndexOutOfRange { .. } => "NodeIndexOutOfRange",
        Error::RepeatedNode { .. } => "RepeatedNode",
        Error::DegenerateTet { .. } => "DegenerateTet",
        Error::NonManifoldFace { .. } => "NonManifoldFace",
        Error::DuplicateTet { .. } => "DuplicateTet",
        Error::InvertedTet { .. } => "InvertedTet",
        Error::UnknownTet { .. } => "UnknownTet",
        Error::DimensionMismatch { .. } => "DimensionMismatch",
        Error::InvalidMaterial { .. } => "InvalidMaterial",
        Error::InvalidParameter { .. } => "InvalidParameter",
        Error::UnknownNode { .. } => "UnknownNode",
        Error::EmptySelection { .. } => "EmptySelection",
        Error::NotConstrained { .. } => "NotConstrained",
        Error::NotPositiveDefinite { .. } => "NotPositiveDefinite",
        Error::Diverged { .. } => "Diverged",
        Error::Interrupted { .. } => "Interrupted",
        Error::Solver(_) => "Solver",
        Error::NotConverged { .. } => "NotConverged",
        Error::Stopped { .. } => "Stopped",
        Error::Parse { .. } => "Parse",
        Error::Scene { .. } => "Scene",
        Error::Io { .. } => "Io",
        _ => "a variant this test does not know",
    }
}

/// Runs each probe under `catch_unwind`, checks its outcome, and lists every probe that
/// panicked or returned something else than expected.
struct Sweep {
    failures: Vec<String>,
    calls: usize,
}

thread_local! {
    static IN_CALL: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

impl Sweep {
    fn new() -> Self {
        // Panics caught inside a probe are not printed (the final assertion lists them); any
        // other panic goes to the default hook. The hook is process-wide and the tests run on
        // several threads, hence the thread-local flag.
        static HOOK: std::sync::Once = std::sync::Once::new();
        HOOK.call_once(|| {
            let default = std::panic::take_hook();
            std::panic::set_hook(Box::new(move |info| {
                if !IN_CALL.with(|c| c.get()) {
                    default(info);
                }
            }));
        });
        Sweep {
            failures: Vec::new(),
            calls: 0,
        }
    }

    /// `f()` under `catch_unwind`; `None` (and the panic listed) if it panicked.
    fn run<T>(&mut self, label: &str, f: impl FnOnce() -> T) -> Option<T> {
        self.calls += 1;
        IN_CALL.with(|c| c.set(true));
        let outcome = catch_unwind(AssertUnwindSafe(f));
        IN_CALL.with(|c| c.set(false));
        match outcome {
            Ok(value) => Some(value),
            Err(payload) => {
                let message = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                self.failures.push(format!("{label}: panicked: {message}"));
                None
            }
        }
    }

    /// The probe must return `Err` of the variant named `expected` (linear-algebra errors
    /// compared as the tetfem variant they convert to, of the same name).
    fn err<T, E: Into<tetfem::Error>>(
        &mut self,
        label: &str,
        expected: &str,
        f: impl FnOnce() -> Result<T, E>,
    ) {
        let found = match self.run(label, || f().map_err(Into::into)) {
            None => return,
            Some(Ok(_)) => "Ok".to_string(),
            Some(Err(e)) if variant(&e) == expected => return,
            Some(Err(e)) => format!("{}: {e}", variant(&e)),
        };
        self.failures
            .push(format!("{label}: expected Err({expected}), got {found}"));
    }

    /// The probe must return `Ok` (the input is odd but valid).
    fn ok<T, E: Into<tetfem::Error>>(&mut self, label: &str, f: impl FnOnce() -> Result<T, E>) {
        if let Some(Err(e)) = self.run(label, || f().map_err(Into::into)) {
            self.failures
                .push(format!("{label}: expected Ok, got {}: {e}", variant(&e)));
        }
    }

    /// The probe returns a plain value (no `Result`): it must return at all.
    fn value<T>(&mut self, label: &str, f: impl FnOnce() -> T) {
        self.run(label, f);
    }

    fn finish(self) {
        assert!(
            self.failures.is_empty(),
            "{} of {} hostile calls panicked or gave another outcome:\n  {}",
            self.failures.len(),
            self.calls,
            self.failures.join("\n  ")
        );
    }
}

fn bar() -> TetMesh {
    TetMesh::box_grid(v(0., 0., 0.), v(3., 1., 1.), [3, 1, 1], BoxSplit::Lecture6).unwrap()
}

fn other_mesh() -> TetMesh {
    TetMesh::box_grid(v(0., 0., 0.), v(2., 1., 1.), [2, 2, 1], BoxSplit::Five).unwrap()
}

fn material() -> Material {
    Material::new(1e5, 0.3, 1000.0).unwrap()
}

fn clamped(mesh: &TetMesh) -> Constraints {
    let mut c = Constraints::new(mesh);
    c.fix_nodes(&mesh.nodes_on_plane(0, 0.0, 1e-9)).unwrap();
    c
}

/// Backward Euler with `model`'s force, lumped mass and no damping on `mesh` (what the removed
/// `NonlinearBackwardEuler::new` built): every error of the set-up passes through.
fn nonlinear_backward_euler(
    mesh: &TetMesh,
    model: ModelKind,
    constraints: &Constraints,
    gravity: Vector3<f64>,
    dt: f64,
    options: IntegratorOptions,
) -> tetfem::Result<(BackwardEuler, Arc<NonlinearForce>, Arc<LinearSystem>)> {
    let m = material();
    let system = Arc::new(LinearSystem::new(
        mesh,
        &m,
        constraints,
        &Loads::new(mesh),
        gravity,
        MassKind::Lumped,
        Rayleigh::default(),
    )?);
    let force = Arc::new(NonlinearForce::new(
        Arc::new(mesh.clone()),
        model.build(&m),
        &system,
    )?);
    let force_of = InternalForce::Nonlinear(Arc::clone(&force));
    let integrator = BackwardEuler::with_force(Arc::clone(&system), force_of, dt, options)?;
    Ok((integrator, force, system))
}

fn bogus_face() -> BoundaryFace {
    BoundaryFace {
        tet: usize::MAX,
        nodes: [0, usize::MAX, 7],
    }
}

#[test]
fn mesh_construction_and_queries() {
    let mut s = Sweep::new();
    let corner = vec![v(0., 0., 0.), v(1., 0., 0.), v(0., 1., 0.), v(0., 0., 1.)];
    s.err("TetMesh::new empty", "EmptyMesh", || {
        TetMesh::new(vec![], vec![])
    });
    s.err(
        "TetMesh::new index usize::MAX",
        "NodeIndexOutOfRange",
        || TetMesh::new(corner.clone(), vec![[0, 1, 2, usize::MAX]]),
    );
    s.err("TetMesh::new NaN", "NonFiniteCoordinate", || {
        TetMesh::new(vec![v(NAN, 0., 0.); 4], vec![[0, 1, 2, 3]])
    });
    s.err("TetMesh::new huge coordinates", "DegenerateTet", || {
        let big = 1e300;
        TetMesh::new(
            vec![
                v(0., 0., 0.),
                v(big, 0., 0.),
                v(0., big, 0.),
                v(0., 0., big),
            ],
            vec![[0, 1, 2, 3]],
        )
    });
    s.err("TetMesh::new tiny coordinates", "DegenerateTet", || {
        let tiny = 1e-300;
        TetMesh::new(
            vec![
                v(0., 0., 0.),
                v(tiny, 0., 0.),
                v(0., tiny, 0.),
                v(0., 0., tiny),
            ],
            vec![[0, 1, 2, 3]],
        )
    });
    s.err("TetMesh::new all nodes equal", "DegenerateTet", || {
        TetMesh::new(vec![v(1., 1., 1.); 4], vec![[0, 1, 2, 3]])
    });
    s.err("box_grid zero cells", "InvalidParameter", || {
        TetMesh::box_grid(v(0., 0., 0.), v(1., 1., 1.), [0, 1, 1], BoxSplit::Five)
    });
    s.err("box_grid NaN extent", "InvalidParameter", || {
        TetMesh::box_grid(v(NAN, 0., 0.), v(1., 1., 1.), [1, 1, 1], BoxSplit::Lecture6)
    });
    s.err("box_grid inverted extent", "InvalidParameter", || {
        TetMesh::box_grid(v(1., 0., 0.), v(0., 1., 1.), [1, 1, 1], BoxSplit::Lecture6)
    });
    s.err("box_grid usize::MAX cells", "InvalidParameter", || {
        TetMesh::box_grid(
            v(0., 0., 0.),
            v(1., 1., 1.),
            [usize::MAX, usize::MAX, 2],
            BoxSplit::Lecture6,
        )
    });
    s.err("box_grid huge extent", "NonFiniteCoordinate", || {
        TetMesh::box_grid(
            v(-1e308, 0., 0.),
            v(1e308, 1., 1.),
            [2, 1, 1],
            BoxSplit::Five,
        )
    });
    let mesh = bar();
    s.err("element(usize::MAX)", "UnknownTet", || {
        mesh.element(usize::MAX)
    });
    s.err("tet_positions(tet_count)", "UnknownTet", || {
        mesh.tet_positions(mesh.tet_count())
    });
    s.err("with_nodes wrong length", "InvalidParameter", || {
        mesh.with_nodes(vec![v(0., 0., 0.)])
    });
    s.err("with_nodes NaN", "NonFiniteCoordinate", || {
        mesh.with_nodes(vec![v(NAN, NAN, NAN); mesh.node_count()])
    });
    s.err("with_nodes collapsed", "DegenerateTet", || {
        mesh.with_nodes(vec![v(0., 0., 0.); mesh.node_count()])
    });
    s.value("nodes_on_plane axis 7", || {
        mesh.nodes_on_plane(7, 0.0, 1e-9)
    });
    s.value("nodes_on_plane NaN", || mesh.nodes_on_plane(0, NAN, NAN));
    s.value("nodes_in_box NaN", || {
        mesh.nodes_in_box(v(NAN, 0., 0.), v(INF, 1., 1.))
    });
    s.value("faces_where bogus faces", || {
        mesh.faces_where(&[bogus_face()], |_| true)
    });
    s.value("faces_on_plane bogus face, axis 9", || {
        mesh.faces_on_plane(&[bogus_face()], 9, 0.0, 1e-9)
    });
    s.err("BoundaryFace::area_vector bogus", "UnknownNode", || {
        bogus_face().area_vector(&mesh)
    });
    s.err("BoundaryFace::centroid bogus", "UnknownNode", || {
        bogus_face().centroid(&mesh)
    });
    s.value("statistics/warnings", || {
        (mesh.statistics(), mesh.warnings())
    });
    s.value("tet_quality of a flat tet", || {
        let element = mesh.element(0).unwrap();
        tet_quality(&element, &[v(0., 0., 0.); 4])
    });
    s.value("shape_quality NaN", || shape_quality(&[v(NAN, 0., 0.); 4]));
    s.value("signed_volume inf", || signed_volume(&[v(INF, 0., 0.); 4]));
    s.value("rest_shape_matrix NaN", || {
        rest_shape_matrix(&[v(NAN, 0., 0.); 4])
    });
    s.err("Tet::new flat", "InvalidParameter", || {
        Tet::new(&[v(0., 0., 0.); 4])
    });
    s.err("Tet::new NaN", "InvalidParameter", || {
        Tet::new(&[v(NAN, 0., 0.); 4])
    });
    s.value("von_mises NaN", || von_mises(&Matrix3::from_element(NAN)));
    s.value("element methods with NaN", || {
        let t = mesh.element(0).unwrap();
        let m = material();
        let u = tetfem::fe::element::Vector12::from_element(NAN);
        (
            t.strain(&u),
            t.stress(&m, &u),
            t.deformation_gradient(&[v(NAN, INF, 0.); 4]),
            t.lecture_face_forces(&m, &[v(NAN, 0., 0.); 4]),
            t.consistent_mass(NAN),
            t.lumped_mass(-1.0),
        )
    });
    s.value("critical_time_step", || {
        tetfem::analysis::dynamics::element_step_bound(&mesh, &material())
    });
    s.value("element_critical_step", || {
        element_critical_step(&mesh, &material())
    });
    s.finish();
}

#[test]
fn materials_loads_constraints() {
    let mut s = Sweep::new();
    for (e, nu, rho) in [
        (NAN, 0.3, 1.0),
        (-1.0, 0.3, 1.0),
        (1.0, 0.5, 1.0),
        (1.0, -1.0, 1.0),
        (1.0, 0.3, 0.0),
        (INF, INF, INF),
    ] {
        s.err(
            &format!("Material::new({e}, {nu}, {rho})"),
            "InvalidMaterial",
            || Material::new(e, nu, rho),
        );
    }
    // Extreme but inside the physical ranges: valid, and its derived moduli must not panic.
    {
        let (e, nu, rho) = (f64::MIN_POSITIVE, 0.4999999, f64::MIN_POSITIVE);
        s.ok(
            "Material::new(MIN_POSITIVE, 0.4999999, MIN_POSITIVE)",
            || {
                Material::new(e, nu, rho).map(|m| {
                    (
                        m.lame_lambda(),
                        m.bulk_modulus(),
                        m.p_wave_speed(),
                        m.tensor_stiffness(),
                        m.warnings(),
                    )
                })
            },
        );
    }
    let mesh = bar();
    let other = other_mesh();
    let m = material();
    let mut c = Constraints::new(&mesh);
    s.err("fix_nodes usize::MAX", "UnknownNode", || {
        c.fix_nodes(&[usize::MAX]).map(|_| ())
    });
    s.err("fix_axes empty", "EmptySelection", || {
        c.fix_axes(&[], [true; 3]).map(|_| ())
    });
    s.err("prescribe NaN", "InvalidParameter", || {
        c.prescribe(0, v(NAN, 0., 0.)).map(|_| ())
    });
    s.err("prescribe_axis axis 3", "InvalidParameter", || {
        c.prescribe_axis(0, 3, 1.0).map(|_| ())
    });
    s.err("prescribe_axis node MAX", "UnknownNode", || {
        c.prescribe_axis(usize::MAX, 0, 1.0).map(|_| ())
    });
    s.value("Constraints::get MAX", || c.get(usize::MAX));
    let mut loads = Loads::new(&mesh);
    s.err("add_gravity other mesh", "InvalidParameter", || {
        loads.add_gravity(&other, &m, v(0., 0., -1.)).map(|_| ())
    });
    s.err("add_gravity NaN", "InvalidParameter", || {
        loads.add_gravity(&mesh, &m, v(NAN, 0., 0.)).map(|_| ())
    });
    s.err("add_body_force inf", "InvalidParameter", || {
        loads.add_body_force(&mesh, v(INF, 0., 0.)).map(|_| ())
    });
    s.err("add_body_force_field NaN", "InvalidParameter", || {
        loads
            .add_body_force_field(&mesh, |_| v(NAN, 0., 0.))
            .map(|_| ())
    });
    s.err(
        "add_body_force_field other mesh",
        "InvalidParameter",
        || {
            loads
                .add_body_force_field(&other, |_| v(1., 0., 0.))
                .map(|_| ())
        },
    );
    s.err("add_nodal_force MAX", "UnknownNode", || {
        loads.add_nodal_force(usize::MAX, v(1., 0., 0.)).map(|_| ())
    });
    s.err("add_traction bogus face", "UnknownNode", || {
        loads
            .add_traction(&mesh, &[bogus_face()], v(1., 0., 0.))
            .map(|_| ())
    });
    s.err(
        "add_total_force_on_faces degenerate face",
        "InvalidParameter",
        || {
            let flat = BoundaryFace {
                tet: 0,
                nodes: [0, 0, 0],
            };
            loads
                .add_total_force_on_faces(&mesh, &[flat], v(1., 0., 0.))
                .map(|_| ())
        },
    );
    s.err("add_traction other mesh's faces", "UnknownNode", || {
        let faces = other.boundary_faces().unwrap();
        loads.add_traction(&mesh, &faces, v(1., 0., 0.)).map(|_| ())
    });
    s.value("resultant", || loads.resultant());
    let dofs = DofMap::new(&clamped(&mesh));
    s.err("DofMap::restrict wrong length", "DimensionMismatch", || {
        dofs.restrict(&[1.0])
    });
    s.err("DofMap::expand wrong length", "DimensionMismatch", || {
        dofs.expand(&[])
    });
    s.value("DofMap::free_index MAX", || dofs.free_index(usize::MAX));
    let k_other = stiffness_matrix(&other, &m).unwrap();
    s.err(
        "DofMap::restriction other pattern",
        "DimensionMismatch",
        || dofs.restriction(k_other.pattern()),
    );
    let k = stiffness_matrix(&mesh, &m).unwrap();
    let restriction = dofs.restriction(k.pattern()).unwrap();
    s.err(
        "Restriction::restrict other matrix",
        "DimensionMismatch",
        || restriction.restrict(&k_other),
    );
    s.err(
        "Restriction::restrict_into wrong out",
        "InvalidParameter",
        || {
            let mut out = k.clone();
            restriction.restrict_into(&k, &mut out)
        },
    );
    s.err("ensure_held other mesh's topology", "UnknownTet", || {
        ensure_held(&mesh, &other.face_topology().unwrap(), &dofs)
    });
    s.err("ensure_held other mesh's dofs", "DimensionMismatch", || {
        ensure_held(&other, &other.face_topology().unwrap(), &dofs)
    });
    s.finish();
}

#[test]
fn assembly_sparse_and_solvers() {
    let mut s = Sweep::new();
    let mesh = bar();
    let other = other_mesh();
    let m = material();
    let assembler = Assembler::new(&mesh);
    let mut k = assembler.stiffness(&mesh, &m).unwrap();
    let k_other = stiffness_matrix(&other, &m).unwrap();
    s.err(
        "Assembler::stiffness other mesh",
        "InvalidParameter",
        || assembler.stiffness(&other, &m),
    );
    s.err(
        "Assembler::consistent_mass other mesh",
        "InvalidParameter",
        || assembler.consistent_mass(&other, &m),
    );
    s.err("Assembler::scatter tet MAX", "UnknownTet", || {
        let mut values = vec![0.0; assembler.nnz()];
        assembler.scatter(&mesh, usize::MAX, &Matrix12::identity(), &mut values)
    });
    s.err(
        "Assembler::scatter short values",
        "DimensionMismatch",
        || assembler.scatter(&mesh, 0, &Matrix12::identity(), &mut [0.0; 3]),
    );
    s.err(
        "Assembler::reassemble other pattern",
        "InvalidParameter",
        || {
            let mut wrong = k_other.clone();
            assembler.reassemble(&mesh, |_| Matrix12::identity(), &mut wrong)
        },
    );
    s.err(
        "Assembler::reassemble other mesh",
        "InvalidParameter",
        || assembler.reassemble(&other, |_| Matrix12::identity(), &mut k),
    );
    s.value("lumped_mass", || lumped_mass(&mesh, &m));
    s.err("CscMatrix::mul wrong length", "DimensionMismatch", || {
        k.mul(&[1.0, 2.0])
    });
    s.err("CscMatrix::mul_vec wrong y", "DimensionMismatch", || {
        let x = vec![1.0; k.dim()];
        k.mul_vec(&x, &mut [0.0; 2])
    });
    s.err(
        "CscMatrix::quadratic_form wrong length",
        "DimensionMismatch",
        || k.quadratic_form(&[]),
    );
    s.value("CscMatrix::get out of range", || k.get(usize::MAX, 0));
    s.err(
        "CscMatrix::from_values wrong length",
        "InvalidParameter",
        || CscMatrix::from_values(Arc::clone(k.pattern()), vec![1.0]),
    );
    s.err(
        "CscMatrix::set_linear_combination other pattern",
        "InvalidParameter",
        || {
            let mut out = k.clone();
            out.set_linear_combination(1.0, &k, 1.0, &k_other)
        },
    );
    s.err(
        "CscMatrix::add_diagonal wrong length",
        "InvalidParameter",
        || {
            let mut out = k.clone();
            out.add_diagonal(1.0, &[1.0])
        },
    );
    // Any pattern has an ordering.
    s.ok("nested_dissection", || nested_dissection(k.pattern()));
    s.err(
        "inverse_permutation out of range",
        "InvalidParameter",
        || inverse_permutation(&[5, 0, 1]),
    );
    s.err("inverse_permutation repeated", "InvalidParameter", || {
        inverse_permutation(&[0, 0, 1])
    });
    // K of an unconstrained body is singular; with NaN it is garbage.
    s.err(
        "SparseCholesky on singular K",
        "NotPositiveDefinite",
        || {
            let mut c = SparseCholesky::analyze(&k)?;
            c.factorize(&k)
        },
    );
    s.err(
        "SparseCholesky factorize other matrix",
        "InvalidParameter",
        || {
            let mut c = SparseCholesky::analyze(&k)?;
            c.factorize(&k_other)
        },
    );
    s.err(
        "SparseCholesky solve before factorize, wrong length",
        "Solver",
        || {
            let mut c = SparseCholesky::analyze(&k)?;
            c.solve_in_place(&mut [1.0; 5])
        },
    );
    // Documented: 0 threads counts as 1.
    s.ok("SparseCholesky threads 0", || {
        SparseCholesky::analyze_with(
            &k,
            CholeskyOptions {
                threads: 0,
                ..Default::default()
            },
        )
    });
    s.err("SparseCholesky on NaN matrix", "InvalidParameter", || {
        let mut poisoned = k.clone();
        poisoned.values_mut()[0] = NAN;
        let mut c = SparseCholesky::analyze(&poisoned)?;
        c.factorize(&poisoned)
    });
    s.err("BlockJacobi::new NaN", "Solver", || {
        let mut poisoned = k.clone();
        poisoned.values_mut().fill(NAN);
        BlockJacobi::new(&poisoned)
    });
    s.err(
        "BlockJacobi::apply wrong length",
        "DimensionMismatch",
        || {
            let p = BlockJacobi::new(&k)?;
            p.apply(&[1.0], &mut [0.0; 2])
        },
    );
    s.err("SmoothedAggregation::new NaN", "Solver", || {
        let mut poisoned = k.clone();
        poisoned.values_mut().fill(NAN);
        SmoothedAggregation::new(&poisoned, None)
    });
    s.err(
        "SmoothedAggregation::apply wrong length",
        "NotPositiveDefinite",
        || {
            let p = SmoothedAggregation::new(&k, None)?;
            p.apply(&[1.0], &mut [0.0; 2])
        },
    );
    s.err(
        "SmoothedAggregation geometry of another size",
        "DimensionMismatch",
        || {
            let modes = NearNullSpace::from_parts(vec![0, 3], 6, vec![0.0; 18])?;
            SmoothedAggregation::with_options(&k, modes, Default::default())
        },
    );
    s.err(
        "conjugate_gradient wrong lengths",
        "InvalidParameter",
        || {
            let p = BlockJacobi::new(&k)?;
            conjugate_gradient(&k, &p, &[1.0], &mut [0.0; 2], CgOptions::default())
        },
    );
    s.err(
        "conjugate_gradient NaN rhs, 0 iterations",
        "InvalidParameter",
        || {
            let p = BlockJacobi::new(&k)?;
            let rhs = vec![NAN; k.dim()];
            let mut x = vec![0.0; k.dim()];
            conjugate_gradient(
                &k,
                &p,
                &rhs,
                &mut x,
                CgOptions {
                    relative_tolerance: NAN,
                    max_iterations: 0,
                },
            )
        },
    );
    for method in [
        LinearMethod::Auto,
        LinearMethod::Direct,
        LinearMethod::Iterative,
    ] {
        // With no memory, the factorization fails; the solve then says it has none.
        s.err(
            &format!("LinearSolver {method:?} wrong lengths"),
            "Solver",
            || {
                let options = SolverOptions {
                    method,
                    memory_budget: Some(0),
                    ..Default::default()
                };
                let mut solver = LinearSolver::analyze(&k, options)?;
                let _ = solver.factorize(&k);
                solver.solve(&k_other, &mut [1.0; 4])
            },
        );
    }
    s.err(
        "StaticSolver constraints of another mesh",
        "InvalidParameter",
        || StaticSolver::new(&mesh, &m, &clamped(&other)),
    );
    s.err(
        "StaticSolver::solve loads of another mesh",
        "InvalidParameter",
        || StaticSolver::new(&mesh, &m, &clamped(&mesh))?.solve(&Loads::new(&other)),
    );
    // 1e308 at one node: the displacement (≈ 1e303) is still finite, a valid answer.
    s.ok("solve_static huge loads", || {
        let mut loads = Loads::new(&mesh);
        loads.add_nodal_force(15, v(1e308, 1e308, 0.)).unwrap();
        solve_static(&mesh, &m, &clamped(&mesh), &loads)
    });
    // u overflows: the error names the scales of the loads, the prescription and K.
    s.err(
        "solve_static huge prescribed displacement",
        "InvalidParameter",
        || {
            let mut c = clamped(&mesh);
            c.prescribe(15, v(1e308, -1e308, 1e308)).unwrap();
            solve_static(&mesh, &m, &c, &Loads::new(&mesh))
        },
    );
    s.finish();
}

#[test]
fn dynamics_models_and_nonlinear() {
    let mut s = Sweep::new();
    let mesh = bar();
    let other = other_mesh();
    let m = material();
    let system = Arc::new(
        LinearSystem::new(
            &mesh,
            &m,
            &clamped(&mesh),
            &Loads::new(&mesh),
            v(0., 0., -9.81),
            MassKind::Consistent,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let n = system.free_count();
    s.err("LinearSystem::new mismatched", "InvalidParameter", || {
        LinearSystem::new(
            &mesh,
            &m,
            &clamped(&other),
            &Loads::new(&other),
            v(NAN, 0., 0.),
            MassKind::Lumped,
            Rayleigh::default(),
        )
    });
    s.err(
        "LinearSystem::from_parts wrong lengths",
        "InvalidParameter",
        || {
            LinearSystem::from_parts(
                system.stiffness().clone(),
                Mass::Lumped(vec![1.0; 3]),
                Rayleigh::default(),
                vec![0.0; 2],
                vec![],
                DofMap::new(&clamped(&other)),
            )
        },
    );
    s.err(
        "LinearSystem::from_parts negative mass",
        "InvalidParameter",
        || {
            LinearSystem::from_parts(
                system.stiffness().clone(),
                Mass::Lumped(vec![-1.0; n]),
                Rayleigh::default(),
                vec![0.0; n],
                vec![0.0; n],
                system.dofs().clone(),
            )
        },
    );
    s.err("energy wrong state", "DimensionMismatch", || {
        system.energy(&State::at_rest(3))
    });
    s.err(
        "energy_with another system's workspace",
        "DimensionMismatch",
        || {
            // A longer bar: more free DOFs than `system`'s.
            let longer =
                TetMesh::box_grid(v(0., 0., 0.), v(4., 1., 1.), [4, 2, 2], BoxSplit::Five).unwrap();
            let other_system = LinearSystem::new(
                &longer,
                &m,
                &clamped(&longer),
                &Loads::new(&longer),
                v(0., 0., -9.81),
                MassKind::Consistent,
                Rayleigh::default(),
            )
            .unwrap();
            system.energy_with(&State::at_rest(n), &mut other_system.energy_workspace())
        },
    );
    s.err(
        "kinetic_energy_with wrong velocity",
        "DimensionMismatch",
        || system.kinetic_energy_with(&[0.0; 1], &mut system.energy_workspace()),
    );
    s.err("energy_potentials wrong state", "DimensionMismatch", || {
        system.energy_potentials(&State::at_rest(0))
    });
    s.err("combine_into other pattern", "InvalidParameter", || {
        let mut out = stiffness_matrix(&other, &m).unwrap();
        system.combine_into(1.0, 1.0, &mut out)
    });
    s.err("Mass::mul_vec wrong length", "DimensionMismatch", || {
        system.mass().mul_vec(&[1.0], &mut [0.0; 3])
    });
    s.err(
        "Mass::quadratic_form wrong length",
        "DimensionMismatch",
        || system.mass().quadratic_form(&[]),
    );
    s.err(
        "mass_inner_product wrong lengths",
        "DimensionMismatch",
        || mass_inner_product(system.mass(), &[1.0], &[1.0, 2.0]),
    );
    // A NaN load factor makes every load NaN: the static solve names the load.
    s.err("with_load_factor NaN", "InvalidParameter", || {
        (*system)
            .clone()
            .with_load_factor(NAN)
            .static_displacement()
    });
    s.err("Rayleigh::new NaN", "InvalidParameter", || {
        Rayleigh::new(NAN, -1.0)
    });
    s.err(
        "Rayleigh::from_damping_ratio zero band",
        "InvalidParameter",
        || Rayleigh::from_damping_ratio(0.05, 0.0, 0.0),
    );
    s.value("Rayleigh::ratio_at 0", || Rayleigh::default().ratio_at(0.0));
    for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
        // `system` has a consistent mass: the explicit method refuses it before anything else.
        let or_explicit = |expected: &'static str| -> &'static str {
            match method {
                Method::Explicit => "InvalidParameter",
                _ => expected,
            }
        };
        s.err(
            &format!("{method:?} with NaN dt"),
            "InvalidParameter",
            || method.integrator(Arc::clone(&system), NAN),
        );
        s.err(
            &format!("{method:?} step wrong state"),
            or_explicit("DimensionMismatch"),
            || {
                let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
                integrator.step(&mut State::at_rest(n - 1))
            },
        );
        s.err(
            &format!("{method:?} step NaN state"),
            or_explicit("Diverged"),
            || {
                let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
                let mut state = State::at_rest(n);
                state.velocity[0] = NAN;
                integrator.step(&mut state)
            },
        );
        let huge_dt = || {
            let mut integrator = method.integrator(Arc::clone(&system), 1e300)?;
            let mut state = State::at_rest(n);
            for _ in 0..3 {
                integrator.step(&mut state)?;
            }
            Ok::<(), tetfem::Error>(())
        };
        let label = format!("{method:?} huge dt");
        match method {
            // dt² = 1e600 overflows: M + dt²·K has an infinite entry, named.
            Method::BackwardEuler => s.err(&label, "InvalidParameter", huge_dt),
            // K + 4/dt²·M is K (finite, SPD): a valid step.
            Method::Newmark => s.ok(&label, huge_dt),
            Method::Explicit => s.err(&label, "InvalidParameter", huge_dt),
        }
        s.err(
            &format!("{method:?} set_time_step -1"),
            "InvalidParameter",
            || {
                let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
                integrator.set_time_step(-1.0)
            },
        );
    }
    s.err("critical_time_step", "InvalidParameter", || {
        critical_time_step(&system)
    });
    // The guard scans the state for finiteness only; it knows no DOF count.
    s.ok("DivergenceGuard::check wrong state", || {
        DivergenceGuard::new(Energy::default()).check(&State::at_rest(1), &Energy::default())
    });
    s.err("State::released_from NaN", "Diverged", || {
        State::released_from(vec![NAN]).ensure_finite("test")
    });
    s.err("lowest_modes 0", "InvalidParameter", || {
        lowest_modes(&system, 0)
    });
    s.err("lowest_modes more than DOFs", "InvalidParameter", || {
        lowest_modes(&system, n + 10)
    });
    for kind in [
        ModelKind::Linear,
        ModelKind::Corotational,
        ModelKind::NeoHookean,
    ] {
        let model = kind.build(&m);
        let element = mesh.element(0).unwrap();
        let rest = mesh.tet_positions(0).unwrap();
        for x in [
            [v(NAN, 0., 0.); 4],
            [v(0., 0., 0.); 4],
            [v(1e300, -1e300, 0.); 4],
        ] {
            s.value(
                &format!("{kind:?} energy/force/tangent on {:?}", x[0]),
                || {
                    (
                        model.energy(&element, &rest, &x),
                        model.force(&element, &rest, &x),
                        project_psd(&model.tangent(&element, &rest, &x)),
                    )
                },
            );
        }
        s.value(&format!("{kind:?} assemble wrong length"), || {
            (
                assemble::energy(&mesh, model.as_ref(), &[1.0]),
                assemble::internal_force(&mesh, model.as_ref(), &[]),
            )
        });
        s.err(
            &format!("{kind:?} refill_tangent other mesh"),
            "InvalidParameter",
            || {
                let assembler = Assembler::new(&other);
                let mut tangent = assembler.stiffness(&other, &m).unwrap();
                assemble::refill_tangent(
                    &mesh,
                    &assembler,
                    model.as_ref(),
                    &vec![0.0; mesh.dof_count()],
                    true,
                    &mut tangent,
                )
            },
        );
        s.err(
            &format!("{kind:?} deformed_positions MAX"),
            "UnknownTet",
            || assemble::deformed_positions(&mesh, usize::MAX, &[]),
        );
        for options in [
            NewtonOptions {
                load_steps: 0,
                ..Default::default()
            },
            NewtonOptions {
                max_iterations: 0,
                tolerance: NAN,
                ..Default::default()
            },
        ] {
            s.err(
                &format!("{kind:?} Newton with {options:?}"),
                "InvalidParameter",
                || {
                    let mut loads = Loads::new(&mesh);
                    loads.add_nodal_force(15, v(0., 0., -1e6)).unwrap();
                    solve_nonlinear_static(&mesh, model.as_ref(), &clamped(&mesh), &loads, options)
                },
            );
        }
        let crush = || {
            let mut loads = Loads::new(&mesh);
            loads.add_nodal_force(15, v(-1e12, 0., 0.)).unwrap();
            solve_nonlinear_static(
                &mesh,
                model.as_ref(),
                &clamped(&mesh),
                &loads,
                NewtonOptions {
                    max_iterations: 5,
                    ..Default::default()
                },
            )
        };
        let label = format!("{kind:?} Newton with a crushing load");
        match kind {
            // Linear: one Newton step solves it, whatever the load.
            ModelKind::Linear => s.ok(&label, crush),
            // The others do not converge in 5 iterations: Newton's error, not a wrong answer.
            _ => s.err(&label, "NotConverged", crush),
        }
    }
    s.value("polar rotation NaN/zero/inf", || {
        (
            tetfem::model::rotation(&Matrix3::from_element(NAN)),
            tetfem::model::rotation(&Matrix3::zeros()),
            tetfem::model::rotation(&Matrix3::from_element(INF)),
        )
    });
    s.err(
        "nonlinear BackwardEuler wrong state",
        "DimensionMismatch",
        || {
            let (mut integrator, force, system) = nonlinear_backward_euler(
                &bar(),
                ModelKind::NeoHookean,
                &clamped(&mesh),
                v(0., 0., -9.81),
                1e-2,
                IntegratorOptions::default(),
            )?;
            let _ = force.energy(&system, &State::at_rest(2));
            integrator.step(&mut State::at_rest(2))
        },
    );
    // The system's set-up refuses them by name (the wrapper had checked the lengths first).
    s.err(
        "nonlinear BackwardEuler other mesh's constraints",
        "InvalidParameter",
        || {
            nonlinear_backward_euler(
                &bar(),
                ModelKind::Corotational,
                &clamped(&other),
                v(0., 0., 0.),
                1e-2,
                IntegratorOptions::default(),
            )
        },
    );
    s.finish();
}

#[test]
fn studies_norms_outputs_and_scenes() {
    let mut s = Sweep::new();
    let mesh = bar();
    let m = material();
    // A study without levels is empty, not invalid (its fits then say they need two levels).
    s.ok("Study::new empty", || Study::new(vec![]));
    s.err("Study::new NaN levels", "InvalidParameter", || {
        Study::new(vec![
            Level {
                h: NAN,
                dofs: 0,
                error: -1.0,
                seconds: INF,
            };
            3
        ])
        .map(|study| (study.observed_orders(), study.fitted_order()))
    });
    s.err("Study::run erroring solver", "Solver", || {
        Study::run([1.0, 0.5], |_| -> tetfem::Result<(f64, usize, f64)> {
            Err(tetfem::Error::Solver("no".into()))
        })
    });
    s.err("fit_slope empty", "InvalidParameter", || {
        fit_slope(Vec::<(f64, f64)>::new())
    });
    s.err("fit_slope one point, NaN", "InvalidParameter", || {
        fit_slope([(NAN, 1.0)])
    });
    s.err("richardson equal values", "InvalidParameter", || {
        richardson(1.0, 1.0, 1.0, 2.0)
    });
    s.err("richardson NaN ratio", "InvalidParameter", || {
        richardson(1.0, 2.0, 3.0, NAN)
    });
    s.err("l2_error wrong length", "InvalidParameter", || {
        l2_error(&mesh, &[1.0], |_| v(0., 0., 0.))
    });
    s.err("energy_error wrong length", "InvalidParameter", || {
        energy_error(&mesh, &m, &[], |_| Matrix3::zeros())
    });
    s.value("quadrature with NaN", || {
        let element = mesh.element(0).unwrap();
        let x = mesh.tet_positions(0).unwrap();
        (
            tet_rule(),
            shape_values(&v(NAN, 0., 0.)),
            integrate(&element, &x, &[], |_, _| NAN),
        )
    });
    let short = [1.0, 2.0];
    s.err("cell_stress wrong length", "InvalidParameter", || {
        cell_stress(&mesh, &m, &short)
    });
    s.err("cell_von_mises wrong length", "InvalidParameter", || {
        cell_von_mises(&mesh, &m, &short)
    });
    s.err(
        "cell_strain_energy_density wrong length",
        "InvalidParameter",
        || cell_strain_energy_density(&mesh, &m, &short),
    );
    s.value("displacement_magnitude ragged length", || {
        displacement_magnitude(&[1.0, 2.0, 3.0, 4.0])
    });
    let dir = std::env::temp_dir().join(format!("tetfem-no-panic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("no/such/dir/file");
    s.value("VtuWriter wrong lengths, odd names", || {
        let values = vec![1.0; 5];
        VtuWriter::new(&mesh)
            .point_field("a\"<b>&", 3, &values)
            .and_then(|w| w.cell_field("c", 0, &values))
            .is_ok()
    });
    // The writers create missing parent folders.
    s.ok("VtuWriter write to a missing dir", || {
        VtuWriter::new(&mesh).write(&missing.with_extension("vtu"))
    });
    s.err("write_result_vtu wrong lengths", "InvalidParameter", || {
        write_result_vtu(&dir.join("r.vtu"), &mesh, &m, &short, Some(&short))
    });
    s.err(
        "PvdCollection push NaN time, write to a missing dir",
        "InvalidParameter",
        || {
            let mut pvd = PvdCollection::new(missing.with_extension("pvd"));
            pvd.push(NAN, Path::new("x.vtu"))?;
            pvd.write()
        },
    );
    s.err("CsvSeries wrong row", "InvalidParameter", || {
        let mut csv = CsvSeries::new(dir.join("s.csv"), vec!["a".into(), "b,\"c".into()])?;
        csv.push(&[1.0])?;
        csv.push(&[NAN, INF])?;
        csv.write()
    });
    s.err("CsvSeries no columns", "InvalidParameter", || {
        CsvSeries::new(dir.join("e.csv"), vec![])
    });
    s.ok("write_atomically to a missing dir", || {
        write_atomically(&missing, |w| w.write_all(b"x"))
    });
    s.err("write_atomically with a failing writer", "Io", || {
        write_atomically(&dir.join("w.txt"), |_| Err(std::io::Error::other("boom")))
    });
    s.ok("write_gmsh to a missing dir", || {
        write_gmsh(&missing.with_extension("msh"), &mesh, &[])
    });
    // (Not `missing.msh`: write_gmsh above created it, with its folders.)
    s.err("read_mesh missing", "Io", || {
        read_mesh(&dir.join("never_written.msh"))
    });
    // A folder is no mesh file: read as a TetGen prefix, whose .node file is missing.
    s.err("read_mesh a directory", "Io", || read_mesh(&dir));
    s.err("read_mesh unknown extension", "Parse", || {
        read_mesh(&dir.join("x.stl"))
    });
    s.err("read_gmsh of a non-mesh file", "Parse", || {
        let path = dir.join("bad.msh");
        std::fs::write(&path, b"\xff\xfe$MeshFormat\n4.1 1 8\n\x00\x01").unwrap();
        read_gmsh(&path)
    });
    s.err("read_tetgen of garbage", "Parse", || {
        std::fs::write(dir.join("bad.node"), "4 3 0 0\n0 0 0 0\n").unwrap();
        std::fs::write(dir.join("bad.ele"), "1 4 0\n0 0 1 2 99999999999999999999\n").unwrap();
        read_tetgen(&dir.join("bad"))
    });
    let u = vec![0.0; mesh.dof_count()];
    let cells = vec![1.0; mesh.tet_count()];
    for (label, field, displacement, options) in [
        (
            "render wrong displacement",
            Field::Cells {
                name: "c",
                values: &cells,
            },
            &short[..],
            RenderOptions::default(),
        ),
        (
            "render wrong field length",
            Field::Nodes {
                name: "n",
                values: &short,
            },
            &u[..],
            RenderOptions::default(),
        ),
        (
            "render zero size, NaN view",
            Field::Cells {
                name: "c",
                values: &cells,
            },
            &u[..],
            RenderOptions {
                width: 0,
                height: 0,
                azimuth_deg: NAN,
                deformation_scale: INF,
                range: Some((NAN, NAN)),
                ..Default::default()
            },
        ),
        (
            "render huge size",
            Field::Cells {
                name: "c",
                values: &cells,
            },
            &u[..],
            RenderOptions {
                width: u32::MAX,
                height: u32::MAX,
                ..Default::default()
            },
        ),
    ] {
        s.value(label, || {
            render(&mesh, displacement, &field, &options).map(|image| image.pixel(u32::MAX, 0))
        });
    }
    s.value("auto_deformation_scale wrong length / NaN", || {
        (
            auto_deformation_scale(&mesh, &short),
            auto_deformation_scale(&mesh, &vec![NAN; mesh.dof_count()]),
        )
    });
    s.value("viridis NaN", || {
        (viridis(NAN), viridis(-INF), viridis(2.0))
    });
    s.value("Chart with empty, NaN and non-positive log data", || {
        let chart = Chart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: true,
            log_y: true,
            series: vec![
                Series::new("empty", vec![], Mark::Line),
                Series::new("bad", vec![(NAN, -1.0), (0.0, INF)], Mark::LinePoints),
            ],
        };
        (
            chart.write_png(&dir.join("c.png"), 0, 0),
            chart.write_png(&dir.join("c.png"), 200, 100),
        )
    });
    s.value("Cantilever with zero cells and NaN sizes", || {
        let c = Cantilever {
            length: NAN,
            cells: [0, 1, 1],
            ..Cantilever::steel_default()
        };
        (c.mesh().is_err(), c.solve().is_err(), c.beam_theory_tip())
    });
    s.value("Cantilever tip_deflection wrong length", || {
        let c = Cantilever::steel_default();
        let mesh = c.mesh().unwrap();
        (c.tip_nodes(&mesh), c.tip_deflection(&mesh, &[]))
    });
    s.value("RectangularCantilever zero size", || {
        let beam = RectangularCantilever {
            length: 0.0,
            width: 0.0,
            height: -1.0,
            material: m,
        };
        (
            beam.timoshenko_end_load(1.0),
            beam.euler_bernoulli_uniform_load(NAN),
        )
    });
    for text in [
        "",
        "[mesh.box]\ncells = [0, 0, 0]\nmax = [1.0, 1.0, 1.0]\n[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\ndensity = 1.0\n",
        "[mesh]\nfile = \"/nonexistent/x.msh\"\n",
        "[mesh.box]\ncells = [18446744073709551615, 1, 1]\nmax = [1.0, 1.0, 1.0]\n",
        "[analysis]\ntype = \"dynamic\"\ndt = nan\nduration = inf\n",
        "title = 5\n[[loads]]\nwhere = 3\n",
        "\u{0}\u{feff}[[[",
    ] {
        // Each is a scene error naming the key (or the TOML syntax error) and the line.
        s.err(
            &format!("Scene::parse + build + run {text:?}"),
            "Scene",
            || {
                Scene::parse(text, "<hostile>", &dir).and_then(|scene| {
                    scene.build()?;
                    tetfem_cli::scene::run_static(&scene)
                })
            },
        );
    }
    s.err("Scene::load missing", "Io", || {
        Scene::load(&missing.with_extension("toml"))
    });
    s.err("mesh_info missing", "Io", || {
        tetfem_cli::info::mesh_info(&missing, None)
    });
    s.finish();
    std::fs::remove_dir_all(&dir).ok();
}

/// A small dynamic scene (a clamped bar under an end load) for the scene entry points.
const DYNAMIC_SCENE: &str = "[mesh.box]\nmax = [1.0, 0.2, 0.2]\ncells = [4, 1, 1]\n\
    [material]\nyoungs_modulus = 1e6\npoisson_ratio = 0.3\ndensity = 1.0\n\
    [[constraints]]\nwhere = { plane = { axis = \"x\", at = 0.0 } }\n\
    [[loads]]\nwhere = { plane = { axis = \"x\", at = 1.0 } }\ntotal_force = [0, 0, -1]\n\
    [analysis]\ntype = \"dynamic\"\ndt = 1e-3\nduration = 0.01\n";

#[test]
fn scenes_integrator_options_amg_and_method_choice() {
    use std::ops::ControlFlow;
    use tetfem::linalg::amg::{AmgOptions, coarsen};
    use tetfem::linalg::linear_solver::{ChoiceInputs, choose_method};
    use tetfem::linalg::ordering::FillOrdering;
    use tetfem::mesh::io::{TetgenOptions, write_tetgen};
    use tetfem_cli::scene::{DynamicOverrides, RunLength, RunOptions, TimeStep, run_dynamic_scene};

    let mut s = Sweep::new();
    let dir = std::env::temp_dir().join(format!("tetfem-no-panic-entry-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = bar();
    let m = material();

    // Scenes: the wrong analysis for the runner, bad overrides, a missing mesh file.
    let dynamic: Scene = DYNAMIC_SCENE.parse().unwrap();
    let static_scene: Scene = DYNAMIC_SCENE
        .replace("\"dynamic\"", "\"static\"")
        .replace("dt = 1e-3\nduration = 0.01\n", "")
        .parse()
        .unwrap();
    let no_files = RunOptions {
        no_files: true,
        ..RunOptions::default()
    };
    let mut go = |_: usize, _: usize| ControlFlow::Continue(());
    s.err("run_static_with on a dynamic scene", "Scene", || {
        tetfem_cli::scene::run_static_with(&dynamic, &no_files)
    });
    s.ok("run_static_with on its static twin", || {
        tetfem_cli::scene::run_static_with(&static_scene, &no_files)
    });
    s.err("run_dynamic_scene on a static scene", "Scene", || {
        run_dynamic_scene(
            &static_scene,
            &DynamicOverrides::default(),
            false,
            false,
            &mut go,
        )
    });
    for (label, overrides) in [
        (
            "run_dynamic_scene dt NaN",
            DynamicOverrides {
                dt: Some(TimeStep::Seconds(NAN)),
                ..Default::default()
            },
        ),
        (
            "run_dynamic_scene dt −1 critical steps",
            DynamicOverrides {
                dt: Some(TimeStep::CriticalMultiple(-1.0)),
                ..Default::default()
            },
        ),
        (
            "run_dynamic_scene 0 steps",
            DynamicOverrides {
                length: Some(RunLength::Steps(0)),
                ..Default::default()
            },
        ),
        (
            "run_dynamic_scene duration NaN",
            DynamicOverrides {
                length: Some(RunLength::Duration(NAN)),
                ..Default::default()
            },
        ),
    ] {
        s.err(label, "InvalidParameter", || {
            run_dynamic_scene(&dynamic, &overrides, false, false, &mut go)
        });
    }
    s.ok("run_dynamic_scene 3 steps", || {
        let overrides = DynamicOverrides {
            length: Some(RunLength::Steps(3)),
            ..Default::default()
        };
        run_dynamic_scene(&dynamic, &overrides, false, false, &mut go)
    });
    s.err("run_static_with a missing mesh file", "Io", || {
        let text = "[mesh.gmsh]\nfile = \"no_such.msh\"\n[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.0\ndensity = 1.0\n";
        let scene = Scene::parse(text, "inline", &dir)?;
        tetfem_cli::scene::run_static_with(&scene, &no_files)
    });
    s.err("TimeStep::from_str garbage", "InvalidParameter", || {
        "fast".parse::<TimeStep>()
    });

    // TetGen output: markers and attributes of the wrong length, a bad base, a missing folder.
    for (label, options) in [
        (
            "write_tetgen short node markers",
            TetgenOptions {
                base: 0,
                node_markers: Some(vec![1]),
                tet_attributes: None,
            },
        ),
        (
            "write_tetgen short tet attributes",
            TetgenOptions {
                base: 1,
                node_markers: None,
                tet_attributes: Some(vec![]),
            },
        ),
        (
            "write_tetgen base 7",
            TetgenOptions {
                base: 7,
                ..TetgenOptions::default()
            },
        ),
    ] {
        s.err(label, "InvalidParameter", || {
            write_tetgen(&dir.join("t"), &mesh, &options)
        });
    }
    // Like the other writers, it creates the missing folders.
    s.ok("write_tetgen into a missing folder", || {
        write_tetgen(&dir.join("no/such/t"), &mesh, &TetgenOptions::default())
    });

    // Assembly into the wrong matrix or for another mesh.
    let assembler = Assembler::new(&mesh);
    let other = other_mesh();
    s.err("refill_stiffness other mesh", "InvalidParameter", || {
        let mut k = assembler.stiffness(&mesh, &m)?;
        assembler.refill_stiffness(&other, &m, &mut k)
    });
    s.err(
        "refill_stiffness matrix of another pattern",
        "InvalidParameter",
        || {
            let mut k = stiffness_matrix(&other, &m)?;
            assembler.refill_stiffness(&mesh, &m, &mut k)
        },
    );

    // Integrators: options, damping, the nonlinear method's Cholesky options.
    let lumped = Arc::new(
        LinearSystem::new(
            &mesh,
            &m,
            &clamped(&mesh),
            &Loads::new(&mesh),
            v(0., 0., -9.81),
            MassKind::Lumped,
            Rayleigh::default(),
        )
        .unwrap(),
    );
    let n = lumped.free_count();
    for method in [Method::BackwardEuler, Method::Newmark] {
        s.err(
            &format!("{method:?} integrator_with CG tolerance NaN"),
            "InvalidParameter",
            || {
                let options = IntegratorOptions {
                    linear_method: LinearMethod::Iterative,
                    cg: CgOptions {
                        relative_tolerance: NAN,
                        max_iterations: 10,
                    },
                    ..IntegratorOptions::default()
                };
                method
                    .integrator_with(Arc::clone(&lumped), 1e-3, options)?
                    .step(&mut State::at_rest(n))
            },
        );
        s.ok(
            &format!("{method:?} integrator_with Cholesky threads 0"),
            || {
                let options = IntegratorOptions {
                    cholesky: CholeskyOptions {
                        threads: 0,
                        ..CholeskyOptions::default()
                    },
                    ..IntegratorOptions::default()
                };
                method
                    .integrator_with(Arc::clone(&lumped), 1e-3, options)?
                    .step(&mut State::at_rest(n))
            },
        );
    }
    for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
        for damping in [
            Rayleigh {
                alpha: -1.0,
                beta: 0.0,
            },
            Rayleigh {
                alpha: 0.0,
                beta: NAN,
            },
        ] {
            s.err(
                &format!("{method:?} with_damping {damping:?}"),
                "InvalidParameter",
                || {
                    let damped = Arc::new((*lumped).clone().with_damping(damping));
                    method
                        .integrator(damped, 1e-4)?
                        .step(&mut State::at_rest(n))
                },
            );
        }
    }
    s.err(
        "LinearSystem::from_parts negative damping",
        "InvalidParameter",
        || {
            LinearSystem::from_parts(
                lumped.stiffness().clone(),
                lumped.mass().clone(),
                Rayleigh {
                    alpha: -1.0,
                    beta: 0.0,
                },
                vec![0.0; n],
                vec![0.0; n],
                lumped.dofs().clone(),
            )
        },
    );
    s.ok("nonlinear BackwardEuler with cholesky threads 0", || {
        let options = IntegratorOptions {
            cholesky: CholeskyOptions {
                threads: 0,
                ..CholeskyOptions::default()
            },
            ..IntegratorOptions::default()
        };
        let (mut integrator, _, _) = nonlinear_backward_euler(
            &mesh,
            ModelKind::Corotational,
            &clamped(&mesh),
            v(0., 0., -9.81),
            1e-3,
            options,
        )?;
        integrator.step(&mut State::at_rest(n))
    });
    s.err("nonlinear BackwardEuler dt NaN", "InvalidParameter", || {
        nonlinear_backward_euler(
            &mesh,
            ModelKind::Corotational,
            &clamped(&mesh),
            v(0., 0., 0.),
            NAN,
            IntegratorOptions::default(),
        )
    });

    // Multigrid coarsening with bad options or a near-null space of another size.
    let k = lumped.stiffness().clone();
    let near_null = NearNullSpace::translations(&k);
    for (label, options) in [
        (
            "coarsen strength NaN",
            AmgOptions {
                strength_threshold: NAN,
                ..AmgOptions::default()
            },
        ),
        (
            "coarsen smoother degree 0",
            AmgOptions {
                smoother_degree: 0,
                ..AmgOptions::default()
            },
        ),
        (
            "coarsen 0 levels",
            AmgOptions {
                max_levels: 0,
                ..AmgOptions::default()
            },
        ),
    ] {
        s.err(label, "InvalidParameter", || {
            coarsen(&k, &near_null, &options)
        });
        s.err(
            &format!("SmoothedAggregation::with_options, {label}"),
            "InvalidParameter",
            || SmoothedAggregation::with_options(&k, near_null.clone(), options),
        );
    }
    s.err(
        "coarsen near-null space of another size",
        "DimensionMismatch",
        || {
            let small = NearNullSpace::translations(&stiffness_matrix(&other, &m)?);
            Ok::<_, tetfem::Error>(coarsen(&k, &small, &AmgOptions::default())?)
        },
    );

    // The method choice: names, and the cost model's inputs.
    s.err("Method::from_str leapfrog", "InvalidParameter", || {
        "leapfrog".parse::<Method>()
    });
    s.err("LinearMethod::from_str magic", "InvalidParameter", || {
        "magic".parse::<LinearMethod>()
    });
    s.err("ModelKind::from_str rubbery", "InvalidParameter", || {
        "rubbery".parse::<ModelKind>()
    });
    s.err("FillOrdering::from_str random", "InvalidParameter", || {
        "random".parse::<FillOrdering>()
    });
    s.ok("choose_method Auto, no memory at all", || {
        let inputs = ChoiceInputs {
            matrix_entries: k.nnz(),
            factor_len: usize::MAX,
            factor_flops: f64::MAX,
            factor_bytes: usize::MAX,
            memory_budget: Some(0),
            cholesky_threads: 0,
            iterative_threads: 0,
            iteration_estimate: false,
        };
        choose_method(
            &inputs,
            &SolverOptions {
                method: LinearMethod::Auto,
                ..SolverOptions::default()
            },
        )
    });
    s.err("choose_method NaN factor flops", "InvalidParameter", || {
        let inputs = ChoiceInputs {
            matrix_entries: k.nnz(),
            factor_len: 1,
            factor_flops: f64::NAN,
            factor_bytes: 1,
            memory_budget: None,
            cholesky_threads: 1,
            iterative_threads: 1,
            iteration_estimate: false,
        };
        choose_method(&inputs, &SolverOptions::default())
    });
    let _ = std::fs::remove_dir_all(&dir);
    s.finish();
}

/// The entry points added since the sweeps above were written: amplitudes and moving
/// supports, rigid obstacles and contact, checkpoints, the error estimate and the adequacy
/// checks, 10-node tets, material maps and the force seam, each with hostile input.
#[test]
fn amplitudes_contact_checkpoints_estimates_tet10_materials_and_forces() {
    use tetfem::Tet10;
    use tetfem::analysis::dynamics::Checkpoint;
    use tetfem::bc::amplitude::Amplitude;
    use tetfem::bc::boundary_motion::RigidMotion;
    use tetfem::contact::{Contact, ContactParameters, Obstacle, ObstacleMotion};
    use tetfem::fe::materials::{MaterialAssignment, MaterialMap};
    use tetfem::post::adequacy::rotation::largest_rotation_and_strain;
    use tetfem::post::adequacy::time_step::step_resolution;
    use tetfem::post::estimate::estimate_error;

    let mut s = Sweep::new();
    let mesh = bar();
    let m = material();

    // Amplitudes: bad tables and intervals are errors; every value is total (NaN time,
    // infinities, a subnormal table interval) and finite where the data are.
    s.err("Amplitude::table empty", "InvalidParameter", || {
        Amplitude::table(vec![], vec![])
    });
    s.err("Amplitude::table lengths", "InvalidParameter", || {
        Amplitude::table(vec![0.0, 1.0], vec![0.0])
    });
    s.err("Amplitude::table decreasing", "InvalidParameter", || {
        Amplitude::table(vec![1.0, 0.0], vec![0.0, 1.0])
    });
    s.err("Amplitude::table NaN value", "InvalidParameter", || {
        Amplitude::table(vec![0.0, 1.0], vec![0.0, NAN])
    });
    s.err("Amplitude::ramp reversed", "InvalidParameter", || {
        Amplitude::ramp(1.0, 0.0)
    });
    s.err(
        "Amplitude::smooth_step infinite",
        "InvalidParameter",
        || Amplitude::smooth_step(0.0, INF),
    );
    s.err(
        "Amplitude::sine negative frequency",
        "InvalidParameter",
        || Amplitude::sine(1.0, -1.0, 0.0, 0.0),
    );
    let table = Amplitude::table(vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 0.5]).unwrap();
    let sine = Amplitude::sine(1.0, 5.0, 0.0, 0.0).unwrap();
    for t in [NAN, INF, -INF, -1e300, 1e300, f64::MIN_POSITIVE] {
        s.value(&format!("Amplitude::derivatives table at {t}"), || {
            table.derivatives(t)
        });
        s.value(&format!("Amplitude::derivatives sine at {t}"), || {
            sine.derivatives(t)
        });
    }
    if let Some(Ok(tiny)) = s.run("Amplitude::table subnormal interval", || {
        Amplitude::table(vec![0.0, 1e-320], vec![0.0, 1.0])
    }) {
        let a = s.run("Amplitude::value inside a subnormal interval", || {
            tiny.derivatives(5e-321)
        });
        if let Some(a) = a.filter(|a| !a[0].is_finite()) {
            s.failures.push(format!(
                "subnormal table interval: a(5e-321) = {a:?}, not finite"
            ));
        }
    }
    s.err("RigidMotion::new zero axis", "InvalidParameter", || {
        RigidMotion::new(
            v(0., 0., 0.),
            v(0., 0., 0.),
            1.0,
            v(0., 0., 0.),
            Amplitude::default(),
        )
    });
    s.err("RigidMotion::new NaN angle", "InvalidParameter", || {
        RigidMotion::new(
            v(1., 0., 0.),
            v(0., 0., 0.),
            NAN,
            v(0., 0., 0.),
            Amplitude::default(),
        )
    });

    // Obstacles and contact: non-finite shapes, friction and motions; the body inside an
    // obstacle; no obstacle; two with one name; bad parameters; wrong lengths.
    s.err("Obstacle::sphere NaN centre", "InvalidParameter", || {
        Obstacle::sphere("s", v(NAN, 0., 0.), 1.0)
    });
    s.err(
        "Obstacle::sphere negative radius",
        "InvalidParameter",
        || Obstacle::sphere("s", v(0., 0., 0.), -1.0),
    );
    s.err(
        "Obstacle::half_space zero normal",
        "InvalidParameter",
        || Obstacle::half_space("g", v(0., 0., 0.), v(0., 0., 0.)),
    );
    s.err(
        "Obstacle::aligned_box min > max",
        "InvalidParameter",
        || Obstacle::aligned_box("b", v(1., 1., 1.), v(0., 0., 0.)),
    );
    s.err(
        "Obstacle::with_friction negative",
        "InvalidParameter",
        || Obstacle::sphere("s", v(10., 0., 0.), 1.0)?.with_friction(-0.5),
    );
    s.err("Obstacle::with_friction NaN", "InvalidParameter", || {
        Obstacle::sphere("s", v(10., 0., 0.), 1.0)?.with_friction(NAN)
    });
    s.err(
        "Obstacle::with_motion infinite velocity",
        "InvalidParameter",
        || {
            Obstacle::sphere("s", v(10., 0., 0.), 1.0)?
                .with_motion(ObstacleMotion::Velocity(v(INF, 0., 0.)))
        },
    );
    let parameters = ContactParameters::for_mesh(&mesh, m.youngs_modulus()).unwrap();
    s.err(
        "ContactParameters::for_mesh E = NaN",
        "InvalidParameter",
        || ContactParameters::for_mesh(&mesh, NAN),
    );
    s.err("Contact::new no obstacle", "InvalidParameter", || {
        Contact::new(&mesh, vec![], parameters)
    });
    s.err(
        "Contact::new two obstacles one name",
        "InvalidParameter",
        || {
            let a = Obstacle::sphere("s", v(10., 0., 0.), 1.0)?;
            let b = Obstacle::sphere("s", v(-10., 0., 0.), 1.0)?;
            Contact::new(&mesh, vec![a, b], parameters)
        },
    );
    s.err("Contact::new zero stiffness", "InvalidParameter", || {
        let bad = ContactParameters {
            stiffness: 0.0,
            ..parameters
        };
        Contact::new(
            &mesh,
            vec![Obstacle::sphere("s", v(10., 0., 0.), 1.0)?],
            bad,
        )
    });
    s.err(
        "Contact::new body inside a half-space",
        "InvalidParameter",
        || {
            let ground = Obstacle::half_space("g", v(0., 0., 0.5), v(0., 0., 1.))?;
            Contact::new(&mesh, vec![ground], parameters)
        },
    );
    let contact = Contact::new(
        &mesh,
        vec![Obstacle::half_space("g", v(0., 0., -0.5), v(0., 0., 1.)).unwrap()],
        parameters,
    )
    .unwrap();
    let dofs = mesh.dof_count();
    s.err("Contact::energy short u", "InvalidParameter", || {
        contact.energy(&[0.0; 3])
    });
    s.err(
        "Contact::add_force short force",
        "DimensionMismatch",
        || contact.add_force(&vec![0.0; dofs], &mut [0.0; 3]),
    );
    s.err("Contact::max_step NaN step", "InvalidParameter", || {
        let mut du = vec![0.0; dofs];
        du[0] = NAN;
        contact.max_step(&vec![0.0; dofs], &du)
    });
    s.err(
        "Contact::set_offsets wrong count",
        "DimensionMismatch",
        || contact.set_offsets(vec![]),
    );
    s.err(
        "Contact::advance_stage wrong count",
        "DimensionMismatch",
        || contact.advance_stage(&vec![0.0; dofs], &[]),
    );
    s.err(
        "Contact::friction_lag_moving wrong count",
        "DimensionMismatch",
        || {
            let u = vec![0.0; dofs];
            contact.friction_lag_moving(&u, &u, (&[], &[]), 1e-3, 0.1)
        },
    );
    s.err("Contact::with_slip_velocity 0", "InvalidParameter", || {
        Contact::new(
            &mesh,
            vec![Obstacle::half_space("g", v(0., 0., -0.5), v(0., 0., 1.))?],
            parameters,
        )?
        .with_slip_velocity(0.0)
    });

    // Checkpoints: empty, truncated and foreign bytes are parse errors naming the file.
    let path = Path::new("hostile/checkpoint.bin");
    s.err("Checkpoint::from_bytes empty", "Parse", || {
        Checkpoint::from_bytes(&[], path)
    });
    s.err("Checkpoint::from_bytes garbage", "Parse", || {
        Checkpoint::from_bytes(&[0xff; 4096], path)
    });
    s.err("Checkpoint::read missing file", "Io", || {
        Checkpoint::read(Path::new("/nonexistent/tetfem/checkpoint.bin"))
    });

    // The error estimate and the adequacy checks: wrong lengths, NaN, tets without material.
    let u = vec![0.0; dofs];
    s.err("estimate_error short u", "DimensionMismatch", || {
        estimate_error(&mesh, &m, &u[1..])
    });
    s.err("estimate_error NaN u", "InvalidParameter", || {
        let mut bad = u.clone();
        bad[4] = NAN;
        estimate_error(&mesh, &m, &bad)
    });
    s.err(
        "estimate_error map of another mesh",
        "InvalidParameter",
        || estimate_error(&mesh, &MaterialMap::uniform(m, 1), &u),
    );
    s.ok("estimate_error of u = 0", || estimate_error(&mesh, &m, &u));
    s.err(
        "largest_rotation_and_strain short u",
        "DimensionMismatch",
        || largest_rotation_and_strain(&mesh, &u[..3]),
    );
    let system = LinearSystem::new(
        &mesh,
        &m,
        &clamped(&mesh),
        &Loads::new(&mesh),
        v(0., 0., -9.81),
        MassKind::Lumped,
        Rayleigh::default(),
    )
    .unwrap();
    let free = system.free_count();
    s.err("step_resolution dt = 0", "InvalidParameter", || {
        step_resolution(&system, &vec![1.0; free], 2, 0.0)
    });
    s.err(
        "step_resolution short excitation",
        "DimensionMismatch",
        || step_resolution(&system, &[1.0], 2, 1e-3),
    );

    // 10-node tets: from a linear mesh; wrong lengths in their estimate.
    let quadratic = s.run("TetMesh::<Tet10>::from_linear", || {
        TetMesh::<Tet10>::from_linear(&mesh)
    });
    if let Some(Ok(quadratic)) = quadratic {
        s.err(
            "estimate_error Tet10 with a Tet4 u",
            "DimensionMismatch",
            || estimate_error(&quadratic, &m, &u),
        );
        s.ok("estimate_error Tet10 u = 0", || {
            estimate_error(&quadratic, &m, &vec![0.0; quadratic.dof_count()])
        });
    } else {
        s.failures
            .push("TetMesh::<Tet10>::from_linear failed".into());
    }

    // Material maps: a tet index out of range, a tet claimed twice, tets without material.
    s.err(
        "MaterialMap::new index out of range",
        "InvalidParameter",
        || MaterialMap::new(vec![m], vec!["a".into()], vec![0, 0, 7]),
    );
    s.err(
        "MaterialMap::new names and materials differ",
        "DimensionMismatch",
        || MaterialMap::new(vec![m], vec![], vec![0]),
    );
    let tets = mesh.tet_count();
    s.err(
        "MaterialAssignment::assign tet out of range",
        "InvalidParameter",
        || MaterialAssignment::new(tets).assign("a", m, [tets + 5]),
    );
    s.err(
        "MaterialAssignment::assign a tet twice",
        "InvalidParameter",
        || {
            let mut assignment = MaterialAssignment::new(tets);
            assignment.assign("a", m, [0])?;
            assignment.assign("b", m, [0])
        },
    );
    s.err(
        "MaterialAssignment::finish without default",
        "InvalidParameter",
        || {
            let mut assignment = MaterialAssignment::new(tets);
            assignment.assign("a", m, [0])?;
            assignment.finish(None)
        },
    );

    // The force seam: a force for another mesh's system.
    let other = Arc::new(other_mesh());
    s.err(
        "NonlinearForce::new another mesh",
        "InvalidParameter",
        || {
            NonlinearForce::new(
                Arc::clone(&other),
                ModelKind::Corotational.build(&m),
                &system,
            )
        },
    );
    s.ok("InternalForce::of_model linear is the fast path", || {
        InternalForce::of_model(Arc::new(bar()), ModelKind::Linear.build(&m), &system).map(
            |force| match force {
                InternalForce::Linear => Ok(()),
                InternalForce::Nonlinear(_) => Err(Error::invalid_parameter(
                    "force",
                    "nonlinear",
                    "the linear model must take the fast path",
                )),
            },
        )?
    });
    s.finish();
}
