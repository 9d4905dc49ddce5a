//! Every public entry point, driven with hostile input under `catch_unwind`: wrong lengths,
//! out-of-range indices, NaN and infinities, empty sets, objects from another mesh, absurd
//! options. Each call may return an error (most must), but none may panic.
//!
//! The calls are collected and all run before the one assertion, so that a failure lists
//! every entry point that panicked, not just the first.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};
use tetfem::amg::{NearNullSpace, SmoothedAggregation};
use tetfem::assembly::{Assembler, lumped_mass, stiffness_matrix};
use tetfem::beam_theory::RectangularCantilever;
use tetfem::cantilever::Cantilever;
use tetfem::chart::{Chart, Mark, Series};
use tetfem::constraints::{DofMap, ensure_held};
use tetfem::convergence::{Level, Study, fit_slope, richardson};
use tetfem::dynamics::{
    DivergenceGuard, Energy, LinearSystem, Mass, MassKind, Method, NonlinearBackwardEuler,
    Rayleigh, State, critical_time_step, element_critical_step,
};
use tetfem::element::{Matrix12, Tet, rest_shape_matrix, shape_quality, signed_volume, von_mises};
use tetfem::error_norms::{energy_error, l2_error};
use tetfem::iterative::{BlockJacobi, CgOptions, Preconditioner, conjugate_gradient};
use tetfem::linear_solver::{LinearMethod, LinearSolver, SolverOptions};
use tetfem::linsolve::{CholeskyOptions, SparseCholesky};
use tetfem::mesh::io::{read_gmsh, read_mesh, read_tetgen, write_gmsh};
use tetfem::mesh::{BoundaryFace, BoxSplit, tet_quality};
use tetfem::modal::{lowest_modes, mass_inner_product};
use tetfem::model::{ModelKind, assemble, project_psd};
use tetfem::nonlinear::{NewtonOptions, solve_nonlinear_static};
use tetfem::ordering::{inverse_permutation, nested_dissection};
use tetfem::output::fields::{
    cell_strain_energy_density, cell_stress, cell_von_mises, displacement_magnitude,
};
use tetfem::output::{CsvSeries, PvdCollection, VtuWriter, write_atomically, write_result_vtu};
use tetfem::quadrature::{integrate, shape_values, tet_rule};
use tetfem::render::{Field, RenderOptions, auto_deformation_scale, render, viridis};
use tetfem::scene::Scene;
use tetfem::sparse::CscMatrix;
use tetfem::statics::StaticSolver;
use tetfem::{Constraints, Loads, Material, TetMesh, solve_static};

const NAN: f64 = f64::NAN;
const INF: f64 = f64::INFINITY;

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

/// Runs each probe under `catch_unwind` and lists the ones that panicked.
struct Sweep {
    panicked: Vec<String>,
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
            panicked: Vec::new(),
            calls: 0,
        }
    }

    fn call<T>(&mut self, label: &str, f: impl FnOnce() -> T) {
        self.calls += 1;
        IN_CALL.with(|c| c.set(true));
        let outcome = catch_unwind(AssertUnwindSafe(|| drop(f())));
        IN_CALL.with(|c| c.set(false));
        if let Err(payload) = outcome {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            self.panicked.push(format!("{label}: {message}"));
        }
    }

    fn finish(self) {
        assert!(
            self.panicked.is_empty(),
            "{} of {} hostile calls panicked:\n  {}",
            self.panicked.len(),
            self.calls,
            self.panicked.join("\n  ")
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
    s.call("TetMesh::new empty", || TetMesh::new(vec![], vec![]));
    s.call("TetMesh::new index usize::MAX", || {
        TetMesh::new(corner.clone(), vec![[0, 1, 2, usize::MAX]])
    });
    s.call("TetMesh::new NaN", || {
        TetMesh::new(vec![v(NAN, 0., 0.); 4], vec![[0, 1, 2, 3]])
    });
    s.call("TetMesh::new huge coordinates", || {
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
    s.call("TetMesh::new tiny coordinates", || {
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
    s.call("TetMesh::new all nodes equal", || {
        TetMesh::new(vec![v(1., 1., 1.); 4], vec![[0, 1, 2, 3]])
    });
    s.call("box_grid zero cells", || {
        TetMesh::box_grid(v(0., 0., 0.), v(1., 1., 1.), [0, 1, 1], BoxSplit::Five)
    });
    s.call("box_grid NaN extent", || {
        TetMesh::box_grid(v(NAN, 0., 0.), v(1., 1., 1.), [1, 1, 1], BoxSplit::Lecture6)
    });
    s.call("box_grid inverted extent", || {
        TetMesh::box_grid(v(1., 0., 0.), v(0., 1., 1.), [1, 1, 1], BoxSplit::Lecture6)
    });
    s.call("box_grid usize::MAX cells", || {
        TetMesh::box_grid(
            v(0., 0., 0.),
            v(1., 1., 1.),
            [usize::MAX, usize::MAX, 2],
            BoxSplit::Lecture6,
        )
    });
    s.call("box_grid huge extent", || {
        TetMesh::box_grid(
            v(-1e308, 0., 0.),
            v(1e308, 1., 1.),
            [2, 1, 1],
            BoxSplit::Five,
        )
    });
    let mesh = bar();
    s.call("element(usize::MAX)", || mesh.element(usize::MAX));
    s.call("tet_positions(tet_count)", || {
        mesh.tet_positions(mesh.tet_count())
    });
    s.call("with_nodes wrong length", || {
        mesh.with_nodes(vec![v(0., 0., 0.)])
    });
    s.call("with_nodes NaN", || {
        mesh.with_nodes(vec![v(NAN, NAN, NAN); mesh.node_count()])
    });
    s.call("with_nodes collapsed", || {
        mesh.with_nodes(vec![v(0., 0., 0.); mesh.node_count()])
    });
    s.call("nodes_on_plane axis 7", || {
        mesh.nodes_on_plane(7, 0.0, 1e-9)
    });
    s.call("nodes_on_plane NaN", || mesh.nodes_on_plane(0, NAN, NAN));
    s.call("nodes_in_box NaN", || {
        mesh.nodes_in_box(v(NAN, 0., 0.), v(INF, 1., 1.))
    });
    s.call("faces_where bogus faces", || {
        mesh.faces_where(&[bogus_face()], |_| true)
    });
    s.call("faces_on_plane bogus face, axis 9", || {
        mesh.faces_on_plane(&[bogus_face()], 9, 0.0, 1e-9)
    });
    s.call("BoundaryFace::area_vector bogus", || {
        bogus_face().area_vector(&mesh)
    });
    s.call("BoundaryFace::centroid bogus", || {
        bogus_face().centroid(&mesh)
    });
    s.call("statistics/warnings", || {
        (mesh.statistics(), mesh.warnings())
    });
    s.call("tet_quality of a flat tet", || {
        let element = mesh.element(0).unwrap();
        tet_quality(&element, &[v(0., 0., 0.); 4])
    });
    s.call("shape_quality NaN", || shape_quality(&[v(NAN, 0., 0.); 4]));
    s.call("signed_volume inf", || signed_volume(&[v(INF, 0., 0.); 4]));
    s.call("rest_shape_matrix NaN", || {
        rest_shape_matrix(&[v(NAN, 0., 0.); 4])
    });
    s.call("Tet::new flat", || Tet::new(&[v(0., 0., 0.); 4]));
    s.call("Tet::new NaN", || Tet::new(&[v(NAN, 0., 0.); 4]));
    s.call("von_mises NaN", || von_mises(&Matrix3::from_element(NAN)));
    s.call("element methods with NaN", || {
        let t = mesh.element(0).unwrap();
        let m = material();
        let u = tetfem::element::Vector12::from_element(NAN);
        (
            t.strain(&u),
            t.stress(&m, &u),
            t.deformation_gradient(&[v(NAN, INF, 0.); 4]),
            t.lecture_face_forces(&m, &[v(NAN, 0., 0.); 4]),
            t.consistent_mass(NAN),
            t.lumped_mass(-1.0),
        )
    });
    s.call("critical_time_step", || {
        tetfem::mesh::critical_time_step(&mesh, &material())
    });
    s.call("element_critical_step", || {
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
        (f64::MIN_POSITIVE, 0.4999999, f64::MIN_POSITIVE),
    ] {
        s.call(&format!("Material::new({e}, {nu}, {rho})"), || {
            Material::new(e, nu, rho).map(|m| {
                (
                    m.lame_lambda(),
                    m.bulk_modulus(),
                    m.p_wave_speed(),
                    m.tensor_stiffness(),
                    m.warnings(),
                )
            })
        });
    }
    let mesh = bar();
    let other = other_mesh();
    let m = material();
    let mut c = Constraints::new(&mesh);
    s.call("fix_nodes usize::MAX", || {
        c.fix_nodes(&[usize::MAX]).map(|_| ())
    });
    s.call("fix_axes empty", || c.fix_axes(&[], [true; 3]).map(|_| ()));
    s.call("prescribe NaN", || {
        c.prescribe(0, v(NAN, 0., 0.)).map(|_| ())
    });
    s.call("prescribe_axis axis 3", || {
        c.prescribe_axis(0, 3, 1.0).map(|_| ())
    });
    s.call("prescribe_axis node MAX", || {
        c.prescribe_axis(usize::MAX, 0, 1.0).map(|_| ())
    });
    s.call("Constraints::get MAX", || c.get(usize::MAX));
    let mut loads = Loads::new(&mesh);
    s.call("add_gravity other mesh", || {
        loads.add_gravity(&other, &m, v(0., 0., -1.)).map(|_| ())
    });
    s.call("add_gravity NaN", || {
        loads.add_gravity(&mesh, &m, v(NAN, 0., 0.)).map(|_| ())
    });
    s.call("add_body_force inf", || {
        loads.add_body_force(&mesh, v(INF, 0., 0.)).map(|_| ())
    });
    s.call("add_body_force_field NaN", || {
        loads
            .add_body_force_field(&mesh, |_| v(NAN, 0., 0.))
            .map(|_| ())
    });
    s.call("add_body_force_field other mesh", || {
        loads
            .add_body_force_field(&other, |_| v(1., 0., 0.))
            .map(|_| ())
    });
    s.call("add_nodal_force MAX", || {
        loads.add_nodal_force(usize::MAX, v(1., 0., 0.)).map(|_| ())
    });
    s.call("add_traction bogus face", || {
        loads
            .add_traction(&mesh, &[bogus_face()], v(1., 0., 0.))
            .map(|_| ())
    });
    s.call("add_total_force_on_faces degenerate face", || {
        let flat = BoundaryFace {
            tet: 0,
            nodes: [0, 0, 0],
        };
        loads
            .add_total_force_on_faces(&mesh, &[flat], v(1., 0., 0.))
            .map(|_| ())
    });
    s.call("add_traction other mesh's faces", || {
        let faces = other.boundary_faces().unwrap();
        loads.add_traction(&mesh, &faces, v(1., 0., 0.)).map(|_| ())
    });
    s.call("resultant", || loads.resultant());
    let dofs = DofMap::new(&clamped(&mesh));
    s.call("DofMap::restrict wrong length", || dofs.restrict(&[1.0]));
    s.call("DofMap::expand wrong length", || dofs.expand(&[]));
    s.call("DofMap::free_index MAX", || dofs.free_index(usize::MAX));
    let k_other = stiffness_matrix(&other, &m).unwrap();
    s.call("DofMap::restriction other pattern", || {
        dofs.restriction(k_other.pattern())
    });
    let k = stiffness_matrix(&mesh, &m).unwrap();
    let restriction = dofs.restriction(k.pattern()).unwrap();
    s.call("Restriction::restrict other matrix", || {
        restriction.restrict(&k_other)
    });
    s.call("Restriction::restrict_into wrong out", || {
        let mut out = k.clone();
        restriction.restrict_into(&k, &mut out)
    });
    s.call("ensure_held other mesh's topology", || {
        ensure_held(&mesh, &other.face_topology().unwrap(), &dofs)
    });
    s.call("ensure_held other mesh's dofs", || {
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
    s.call("Assembler::stiffness other mesh", || {
        assembler.stiffness(&other, &m)
    });
    s.call("Assembler::consistent_mass other mesh", || {
        assembler.consistent_mass(&other, &m)
    });
    s.call("Assembler::scatter tet MAX", || {
        let mut values = vec![0.0; assembler.nnz()];
        assembler.scatter(&mesh, usize::MAX, &Matrix12::identity(), &mut values)
    });
    s.call("Assembler::scatter short values", || {
        assembler.scatter(&mesh, 0, &Matrix12::identity(), &mut [0.0; 3])
    });
    s.call("Assembler::reassemble other pattern", || {
        let mut wrong = k_other.clone();
        assembler.reassemble(&mesh, |_| Matrix12::identity(), &mut wrong)
    });
    s.call("Assembler::reassemble other mesh", || {
        assembler.reassemble(&other, |_| Matrix12::identity(), &mut k)
    });
    s.call("lumped_mass", || lumped_mass(&mesh, &m));
    s.call("CscMatrix::mul wrong length", || k.mul(&[1.0, 2.0]));
    s.call("CscMatrix::mul_vec wrong y", || {
        let x = vec![1.0; k.dim()];
        k.mul_vec(&x, &mut [0.0; 2])
    });
    s.call("CscMatrix::quadratic_form wrong length", || {
        k.quadratic_form(&[])
    });
    s.call("CscMatrix::get out of range", || k.get(usize::MAX, 0));
    s.call("CscMatrix::from_values wrong length", || {
        CscMatrix::from_values(Arc::clone(k.pattern()), vec![1.0])
    });
    s.call("CscMatrix::set_linear_combination other pattern", || {
        let mut out = k.clone();
        out.set_linear_combination(1.0, &k, 1.0, &k_other)
    });
    s.call("CscMatrix::add_diagonal wrong length", || {
        let mut out = k.clone();
        out.add_diagonal(1.0, &[1.0])
    });
    s.call("nested_dissection", || nested_dissection(k.pattern()));
    s.call("inverse_permutation out of range", || {
        inverse_permutation(&[5, 0, 1])
    });
    s.call("inverse_permutation repeated", || {
        inverse_permutation(&[0, 0, 1])
    });
    // K of an unconstrained body is singular; with NaN it is garbage.
    s.call("SparseCholesky on singular K", || {
        let mut c = SparseCholesky::analyze(&k)?;
        c.factorize(&k)
    });
    s.call("SparseCholesky factorize other matrix", || {
        let mut c = SparseCholesky::analyze(&k)?;
        c.factorize(&k_other)
    });
    s.call(
        "SparseCholesky solve before factorize, wrong length",
        || {
            let mut c = SparseCholesky::analyze(&k)?;
            c.solve_in_place(&mut [1.0; 5])
        },
    );
    s.call("SparseCholesky threads 0", || {
        SparseCholesky::analyze_with(
            &k,
            CholeskyOptions {
                threads: 0,
                ..Default::default()
            },
        )
    });
    s.call("SparseCholesky on NaN matrix", || {
        let mut poisoned = k.clone();
        poisoned.values_mut()[0] = NAN;
        let mut c = SparseCholesky::analyze(&poisoned)?;
        c.factorize(&poisoned)
    });
    s.call("BlockJacobi::new NaN", || {
        let mut poisoned = k.clone();
        poisoned.values_mut().fill(NAN);
        BlockJacobi::new(&poisoned)
    });
    s.call("BlockJacobi::apply wrong length", || {
        let p = BlockJacobi::new(&k)?;
        p.apply(&[1.0], &mut [0.0; 2])
    });
    s.call("SmoothedAggregation::new NaN", || {
        let mut poisoned = k.clone();
        poisoned.values_mut().fill(NAN);
        SmoothedAggregation::new(&poisoned, None)
    });
    s.call("SmoothedAggregation::apply wrong length", || {
        let p = SmoothedAggregation::new(&k, None)?;
        p.apply(&[1.0], &mut [0.0; 2])
    });
    s.call("SmoothedAggregation geometry of another size", || {
        let modes = NearNullSpace::from_parts(vec![0, 3], 6, vec![0.0; 18])?;
        SmoothedAggregation::with_options(&k, modes, Default::default())
    });
    s.call("conjugate_gradient wrong lengths", || {
        let p = BlockJacobi::new(&k)?;
        conjugate_gradient(&k, &p, &[1.0], &mut [0.0; 2], CgOptions::default())
    });
    s.call("conjugate_gradient NaN rhs, 0 iterations", || {
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
    });
    for method in [
        LinearMethod::Auto,
        LinearMethod::Direct,
        LinearMethod::Iterative,
    ] {
        s.call(&format!("LinearSolver {method:?} wrong lengths"), || {
            let options = SolverOptions {
                method,
                memory_budget: Some(0),
                ..Default::default()
            };
            let mut solver = LinearSolver::analyze(&k, options)?;
            let _ = solver.factorize(&k);
            solver.solve(&k_other, &mut [1.0; 4])
        });
    }
    s.call("StaticSolver constraints of another mesh", || {
        StaticSolver::new(&mesh, &m, &clamped(&other))
    });
    s.call("StaticSolver::solve loads of another mesh", || {
        StaticSolver::new(&mesh, &m, &clamped(&mesh))?.solve(&Loads::new(&other))
    });
    s.call("solve_static huge loads", || {
        let mut loads = Loads::new(&mesh);
        loads.add_nodal_force(15, v(1e308, 1e308, 0.)).unwrap();
        solve_static(&mesh, &m, &clamped(&mesh), &loads)
    });
    s.call("solve_static huge prescribed displacement", || {
        let mut c = clamped(&mesh);
        c.prescribe(15, v(1e308, -1e308, 1e308)).unwrap();
        solve_static(&mesh, &m, &c, &Loads::new(&mesh))
    });
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
    s.call("LinearSystem::new mismatched", || {
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
    s.call("LinearSystem::from_parts wrong lengths", || {
        LinearSystem::from_parts(
            system.stiffness().clone(),
            Mass::Lumped(vec![1.0; 3]),
            Rayleigh::default(),
            vec![0.0; 2],
            vec![],
            DofMap::new(&clamped(&other)),
        )
    });
    s.call("LinearSystem::from_parts negative mass", || {
        LinearSystem::from_parts(
            system.stiffness().clone(),
            Mass::Lumped(vec![-1.0; n]),
            Rayleigh::default(),
            vec![0.0; n],
            vec![0.0; n],
            system.dofs().clone(),
        )
    });
    s.call("energy wrong state", || system.energy(&State::at_rest(3)));
    s.call("energy_using short scratch", || {
        system.energy_using(&State::at_rest(n), &mut [0.0; 1])
    });
    s.call("energy_potentials wrong state", || {
        system.energy_potentials(&State::at_rest(0))
    });
    s.call("combine_into other pattern", || {
        let mut out = stiffness_matrix(&other, &m).unwrap();
        system.combine_into(1.0, 1.0, &mut out)
    });
    s.call("Mass::mul_vec wrong length", || {
        system.mass().mul_vec(&[1.0], &mut [0.0; 3])
    });
    s.call("Mass::quadratic_form wrong length", || {
        system.mass().quadratic_form(&[])
    });
    s.call("mass_inner_product wrong lengths", || {
        mass_inner_product(system.mass(), &[1.0], &[1.0, 2.0])
    });
    s.call("with_load_factor NaN", || {
        (*system)
            .clone()
            .with_load_factor(NAN)
            .static_displacement()
    });
    s.call("Rayleigh::new NaN", || Rayleigh::new(NAN, -1.0));
    s.call("Rayleigh::from_damping_ratio zero band", || {
        Rayleigh::from_damping_ratio(0.05, 0.0, 0.0)
    });
    s.call("Rayleigh::ratio_at 0", || Rayleigh::default().ratio_at(0.0));
    for method in [Method::BackwardEuler, Method::Newmark, Method::Explicit] {
        s.call(&format!("{method:?} with NaN dt"), || {
            method.integrator(Arc::clone(&system), NAN)
        });
        s.call(&format!("{method:?} step wrong state"), || {
            let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
            integrator.step(&mut State::at_rest(n - 1))
        });
        s.call(&format!("{method:?} step NaN state"), || {
            let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
            let mut state = State::at_rest(n);
            state.velocity[0] = NAN;
            integrator.step(&mut state)
        });
        s.call(&format!("{method:?} huge dt"), || {
            let mut integrator = method.integrator(Arc::clone(&system), 1e300)?;
            let mut state = State::at_rest(n);
            for _ in 0..3 {
                integrator.step(&mut state)?;
            }
            Ok::<(), tetfem::Error>(())
        });
        s.call(&format!("{method:?} set_time_step -1"), || {
            let mut integrator = method.integrator(Arc::clone(&system), 1e-3)?;
            integrator.set_time_step(-1.0)
        });
    }
    s.call("critical_time_step", || critical_time_step(&system));
    s.call("DivergenceGuard::check wrong state", || {
        DivergenceGuard::new(Energy::default()).check(&State::at_rest(1), &Energy::default())
    });
    s.call("State::released_from NaN", || {
        State::released_from(vec![NAN]).ensure_finite("test")
    });
    s.call("lowest_modes 0", || lowest_modes(&system, 0));
    s.call("lowest_modes more than DOFs", || {
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
            s.call(
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
        s.call(&format!("{kind:?} assemble wrong length"), || {
            (
                assemble::energy(&mesh, model.as_ref(), &[1.0]),
                assemble::internal_force(&mesh, model.as_ref(), &[]),
            )
        });
        s.call(&format!("{kind:?} refill_tangent other mesh"), || {
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
        });
        s.call(&format!("{kind:?} deformed_positions MAX"), || {
            assemble::deformed_positions(&mesh, usize::MAX, &[])
        });
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
            s.call(&format!("{kind:?} Newton with {options:?}"), || {
                let mut loads = Loads::new(&mesh);
                loads.add_nodal_force(15, v(0., 0., -1e6)).unwrap();
                solve_nonlinear_static(&mesh, model.as_ref(), &clamped(&mesh), &loads, options)
            });
        }
        s.call(&format!("{kind:?} Newton with a crushing load"), || {
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
        });
    }
    s.call("polar rotation NaN/zero/inf", || {
        (
            tetfem::model::rotation(&Matrix3::from_element(NAN)),
            tetfem::model::rotation(&Matrix3::zeros()),
            tetfem::model::rotation(&Matrix3::from_element(INF)),
        )
    });
    s.call("NonlinearBackwardEuler wrong state", || {
        let mut integrator = NonlinearBackwardEuler::new(
            Arc::new(bar()),
            &m,
            ModelKind::NeoHookean.build(&m),
            &clamped(&mesh),
            &Loads::new(&mesh),
            v(0., 0., -9.81),
            1e-2,
        )?;
        let _ = integrator.energy(&State::at_rest(2));
        integrator.step(&mut State::at_rest(2))
    });
    s.call("NonlinearBackwardEuler other mesh's constraints", || {
        NonlinearBackwardEuler::new(
            Arc::new(bar()),
            &m,
            ModelKind::Corotational.build(&m),
            &clamped(&other),
            &Loads::new(&other),
            v(0., 0., 0.),
            1e-2,
        )
    });
    s.finish();
}

#[test]
fn studies_norms_outputs_and_scenes() {
    let mut s = Sweep::new();
    let mesh = bar();
    let m = material();
    s.call("Study::new empty", || Study::new(vec![]));
    s.call("Study::new NaN levels", || {
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
    s.call("Study::run erroring solver", || {
        Study::run([1.0, 0.5], |_| -> tetfem::Result<(f64, usize, f64)> {
            Err(tetfem::Error::Solver("no".into()))
        })
    });
    s.call("fit_slope empty", || fit_slope(Vec::<(f64, f64)>::new()));
    s.call("fit_slope one point, NaN", || fit_slope([(NAN, 1.0)]));
    s.call("richardson equal values", || richardson(1.0, 1.0, 1.0, 2.0));
    s.call("richardson NaN ratio", || richardson(1.0, 2.0, 3.0, NAN));
    s.call("l2_error wrong length", || {
        l2_error(&mesh, &[1.0], |_| v(0., 0., 0.))
    });
    s.call("energy_error wrong length", || {
        energy_error(&mesh, &m, &[], |_| Matrix3::zeros())
    });
    s.call("quadrature with NaN", || {
        let element = mesh.element(0).unwrap();
        let x = mesh.tet_positions(0).unwrap();
        (
            tet_rule(),
            shape_values(&v(NAN, 0., 0.)),
            integrate(&element, &x, &[], |_, _| NAN),
        )
    });
    let short = [1.0, 2.0];
    s.call("cell_stress wrong length", || {
        cell_stress(&mesh, &m, &short)
    });
    s.call("cell_von_mises wrong length", || {
        cell_von_mises(&mesh, &m, &short)
    });
    s.call("cell_strain_energy_density wrong length", || {
        cell_strain_energy_density(&mesh, &m, &short)
    });
    s.call("displacement_magnitude ragged length", || {
        displacement_magnitude(&[1.0, 2.0, 3.0, 4.0])
    });
    let dir = std::env::temp_dir().join(format!("tetfem-no-panic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("no/such/dir/file");
    s.call("VtuWriter wrong lengths, odd names", || {
        let values = vec![1.0; 5];
        VtuWriter::new(&mesh)
            .point_field("a\"<b>&", 3, &values)
            .and_then(|w| w.cell_field("c", 0, &values))
            .is_ok()
    });
    s.call("VtuWriter write to a missing dir", || {
        VtuWriter::new(&mesh).write(&missing.with_extension("vtu"))
    });
    s.call("write_result_vtu wrong lengths", || {
        write_result_vtu(&dir.join("r.vtu"), &mesh, &m, &short, Some(&short))
    });
    s.call(
        "PvdCollection push NaN time, write to a missing dir",
        || {
            let mut pvd = PvdCollection::new(missing.with_extension("pvd"));
            pvd.push(NAN, Path::new("x.vtu"))?;
            pvd.write()
        },
    );
    s.call("CsvSeries wrong row", || {
        let mut csv = CsvSeries::new(dir.join("s.csv"), vec!["a".into(), "b,\"c".into()])?;
        csv.push(&[1.0])?;
        csv.push(&[NAN, INF])?;
        csv.write()
    });
    s.call("CsvSeries no columns", || {
        CsvSeries::new(dir.join("e.csv"), vec![])
    });
    s.call("write_atomically to a missing dir", || {
        write_atomically(&missing, |w| w.write_all(b"x"))
    });
    s.call("write_atomically with a failing writer", || {
        write_atomically(&dir.join("w.txt"), |_| Err(std::io::Error::other("boom")))
    });
    s.call("write_gmsh to a missing dir", || {
        write_gmsh(&missing.with_extension("msh"), &mesh, &[])
    });
    s.call("read_mesh missing, a directory, unknown extension", || {
        (
            read_mesh(&missing.with_extension("msh")).is_err(),
            read_mesh(&dir).is_err(),
            read_mesh(&dir.join("x.stl")).is_err(),
        )
    });
    s.call("read_gmsh of a non-mesh file", || {
        let path = dir.join("bad.msh");
        std::fs::write(&path, b"\xff\xfe$MeshFormat\n4.1 1 8\n\x00\x01").unwrap();
        read_gmsh(&path)
    });
    s.call("read_tetgen of garbage", || {
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
        s.call(label, || {
            render(&mesh, displacement, &field, &options).map(|image| image.pixel(u32::MAX, 0))
        });
    }
    s.call("auto_deformation_scale wrong length / NaN", || {
        (
            auto_deformation_scale(&mesh, &short),
            auto_deformation_scale(&mesh, &vec![NAN; mesh.dof_count()]),
        )
    });
    s.call("viridis NaN", || {
        (viridis(NAN), viridis(-INF), viridis(2.0))
    });
    s.call("Chart with empty, NaN and non-positive log data", || {
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
    s.call("Cantilever with zero cells and NaN sizes", || {
        let c = Cantilever {
            length: NAN,
            cells: [0, 1, 1],
            ..Cantilever::steel_default()
        };
        (c.mesh().is_err(), c.solve().is_err(), c.beam_theory_tip())
    });
    s.call("Cantilever tip_deflection wrong length", || {
        let c = Cantilever::steel_default();
        let mesh = c.mesh().unwrap();
        (c.tip_nodes(&mesh), c.tip_deflection(&mesh, &[]))
    });
    s.call("RectangularCantilever zero size", || {
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
        s.call(&format!("Scene::parse + build + run {text:?}"), || {
            Scene::parse(text, "<hostile>", &dir).and_then(|scene| {
                scene.build()?;
                tetfem::scene::run_static(&scene)
            })
        });
    }
    s.call("Scene::load missing", || {
        Scene::load(&missing.with_extension("toml"))
    });
    s.call("mesh_info missing", || {
        tetfem::info::mesh_info(&missing, None)
    });
    s.finish();
    std::fs::remove_dir_all(&dir).ok();
}
