//! The force models on an element type: energy, force, tangent and stress of one element of
//! a mesh, for [`super::assemble`] to sum. The 4-node tet keeps its own closed forms (F is
//! constant in it: one point, the formulas of each [`ForceModel`]); other elements integrate
//! the model's [`ConstitutiveLaw`](super::ConstitutiveLaw) at their quadrature points
//! ([`super::quadrature_points`]).

use nalgebra::{Matrix3, Vector3};

use super::{ForceModel, TetModels, Vector12, project_psd};
use crate::base::error::Result;
use crate::fe::assembly::Assembler;
use crate::fe::element::{ElementType, Tet, Tet4};
use crate::mesh::{CellType, NodeList, TetMesh};
use crate::sparse::CscMatrix;

/// An element type the force models run on. Every method takes a tet `t` of `mesh` and the
/// full displacement `u` (3 values per node, DOF `3·node + axis`), both checked by the caller.
pub trait ModelElement: ElementType + 'static {
    /// Elastic energy Eₑ = ∫ψ(F) dV of tet `t` (energy units).
    fn model_energy(model: &dyn ForceModel, mesh: &TetMesh<Self>, t: usize, u: &[f64]) -> f64;

    /// Adds tet `t`'s internal force fₐ = −∫P(F)·∇Nₐ dV (force units) into the full vector
    /// `force` at its nodes' DOFs.
    fn add_model_force(
        model: &dyn ForceModel,
        mesh: &TetMesh<Self>,
        t: usize,
        u: &[f64],
        force: &mut [f64],
    );

    /// Adds Σₑ fₑ over every tet into the full vector `force`, each tet's force added at its
    /// nodes in tet order (the order fixes the bits, whatever the threads).
    fn add_model_forces(
        mesh: &TetMesh<Self>,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) {
        for t in 0..mesh.tet_count() {
            Self::add_model_force(models.model_of(t), mesh, t, u, force);
        }
    }

    /// [`add_model_forces`](Self::add_model_forces), returning Σₑ Eₑ (energy units) too,
    /// summed in tet order.
    fn add_model_forces_and_energy(
        mesh: &TetMesh<Self>,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) -> f64 {
        Self::add_model_forces(mesh, models, u, force);
        (0..mesh.tet_count())
            .map(|t| Self::model_energy(models.model_of(t), mesh, t, u))
            .sum()
    }

    /// [`add_model_forces_and_energy`](Self::add_model_forces_and_energy) with tet `t`'s rest
    /// element (Dm⁻¹, V, ∇Nₐ of its corners) read from `kept[t]` instead of rebuilt from the
    /// nodes: the same bits, without an inverse and a determinant per tet and pass. The
    /// 4-node tet reads them; an element whose rest data is its own (the 10-node tet's
    /// quadrature) ignores `kept`. `kept` holds one element per tet (checked by the caller).
    fn add_model_forces_and_energy_kept(
        mesh: &TetMesh<Self>,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) -> f64 {
        let _ = kept;
        Self::add_model_forces_and_energy(mesh, models, u, force)
    }

    /// Adds Σₑ (fₑ(u) − fₑ(base)) over the tets `tets` into the full vector `force` and
    /// returns Σₑ (Eₑ(u) − Eₑ(base)) (force and energy units), each tet's rest element from
    /// `kept`: a pass's force and energy carried from `base` to a `u` that differs from it only
    /// at the nodes of `tets`. `None` where the element type does not offer it (then a full
    /// pass is due); the 4-node tet does.
    fn add_model_force_changes_kept(
        mesh: &TetMesh<Self>,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        tets: &[usize],
        (base, u): (&[f64], &[f64]),
        force: &mut [f64],
    ) -> Option<f64> {
        let _ = (mesh, kept, models, tets, base, u, force);
        None
    }

    /// [`model_energy`](Self::model_energy) with tet `t`'s rest element read from `kept[t]`
    /// (as [`add_model_forces_and_energy_kept`](Self::add_model_forces_and_energy_kept)): the
    /// same bits.
    fn model_energy_kept(
        model: &dyn ForceModel,
        mesh: &TetMesh<Self>,
        kept: &[Tet],
        t: usize,
        u: &[f64],
    ) -> f64 {
        let _ = kept;
        Self::model_energy(model, mesh, t, u)
    }

    /// Σₑ Eₑ (energy units) over the tets `tets`, summed in tet order, each tet's rest element
    /// read from `kept`: the same bits as [`model_energy_kept`](Self::model_energy_kept) of
    /// one tet after another.
    fn model_energies_kept(
        mesh: &TetMesh<Self>,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        tets: std::ops::Range<usize>,
    ) -> f64 {
        tets.map(|t| Self::model_energy_kept(models.model_of(t), mesh, kept, t, u))
            .sum()
    }

    /// Refills `tangent` (on `assembler`'s pattern) with Σₑ Kₑ, Kₑ = −∂fₑ/∂x (force/length),
    /// each projected onto the positive semi-definite cone when `project` is set.
    fn refill_model_tangent(
        mesh: &TetMesh<Self>,
        assembler: &Assembler,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        project: bool,
        tangent: &mut CscMatrix,
    ) -> Result<()>;

    /// [`refill_model_tangent`](Self::refill_model_tangent) with each tet's rest element read
    /// from `kept` (one per tet, checked by the caller): the same bits.
    fn refill_model_tangent_kept(
        mesh: &TetMesh<Self>,
        kept: &[Tet],
        assembler: &Assembler,
        models: &(impl TetModels + ?Sized),
        (u, project): (&[f64], bool),
        tangent: &mut CscMatrix,
    ) -> Result<()> {
        let _ = kept;
        Self::refill_model_tangent(mesh, assembler, models, u, project, tangent)
    }

    /// The model's Cauchy stress σ of tet `t` (stress units): the tet's constant stress for
    /// the 4-node tet, the volume average (1/V)∫σ dV over the quadrature points otherwise.
    fn model_cauchy_stress(
        model: &dyn ForceModel,
        mesh: &TetMesh<Self>,
        t: usize,
        u: &[f64],
    ) -> Matrix3<f64>;

    /// The volume average (1/V)∫E dV of the Green–Lagrange strain E = ½(FᵀF − I)
    /// (dimensionless) of tet `t`.
    fn mean_green_strain(mesh: &TetMesh<Self>, t: usize, u: &[f64]) -> Matrix3<f64>;
}

/// x = X + u for the 4 nodes of tet `t`.
#[inline(always)]
pub(crate) fn positions(mesh: &TetMesh, t: usize, u: &[f64]) -> [Vector3<f64>; 4] {
    corners(mesh, t, u).1
}

/// The rest positions X and the deformed ones x = X + u of tet `t`'s 4 corner nodes, from one
/// read of each node (a force pass needs both: a plain loop, not `array::map`, whose generic
/// helpers are not always inlined there and cost as much as a tet's arithmetic).
#[inline(always)]
pub(crate) fn corners<C: CellType>(
    mesh: &TetMesh<C>,
    t: usize,
    u: &[f64],
) -> ([Vector3<f64>; 4], [Vector3<f64>; 4]) {
    let (nodes, tet) = (mesh.nodes(), mesh.tets()[t].corners());
    let mut rest = [Vector3::zeros(); 4];
    let mut x = [Vector3::zeros(); 4];
    for ((rest, x), &n) in rest.iter_mut().zip(&mut x).zip(&tet) {
        *rest = nodes[n];
        *x = *rest + Vector3::new(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
    }
    (rest, x)
}

/// The 4-node tet: each model's own one-point formulas, exactly as before the seam.
impl ModelElement for Tet4 {
    #[inline]
    fn model_energy(model: &dyn ForceModel, mesh: &TetMesh, t: usize, u: &[f64]) -> f64 {
        model.energy(
            &mesh.element_of(t),
            &mesh.positions_of(t),
            &positions(mesh, t, u),
        )
    }

    #[inline]
    fn model_energy_kept(
        model: &dyn ForceModel,
        mesh: &TetMesh,
        kept: &[Tet],
        t: usize,
        u: &[f64],
    ) -> f64 {
        model.energy(&kept[t], &mesh.positions_of(t), &positions(mesh, t, u))
    }

    /// Four tets at a time side by side where their model [evaluates
    /// four](ForceModel::evaluates_four) (their forces computed and dropped: the corotational
    /// energy alone, one tet after another, took 1.9× a force-and-energy pass of the lanes at
    /// 9,720 DOFs); each energy the same bits as [`ForceModel::energy`]'s, summed in tet order.
    fn model_energies_kept(
        mesh: &TetMesh,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        tets: std::ops::Range<usize>,
    ) -> f64 {
        if tets.is_empty() || !models.model_of(tets.start).evaluates_four() {
            return tets
                .map(|t| Self::model_energy_kept(models.model_of(t), mesh, kept, t, u))
                .sum();
        }
        let mut out = [(Vector12::zeros(), 0.0); 4];
        let mut sum = 0.0;
        for first in tets.clone().step_by(4) {
            let out = &mut out[..(tets.end - first).min(4)];
            four_tets(mesh, kept, models, u, first, out);
            for (_, energy) in out.iter() {
                sum += energy;
            }
        }
        sum
    }

    fn add_model_force_changes_kept(
        mesh: &TetMesh,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        tets: &[usize],
        (base, u): (&[f64], &[f64]),
        force: &mut [f64],
    ) -> Option<f64> {
        let mut change = 0.0;
        for &t in tets {
            let model = models.model_of(t);
            let (rest, before) = corners(mesh, t, base);
            let (_, after) = corners(mesh, t, u);
            let (f0, e0) = model.force_and_energy(&kept[t], &rest, &before);
            let (f1, e1) = model.force_and_energy(&kept[t], &rest, &after);
            for (i, &n) in mesh.tets()[t].iter().enumerate() {
                for a in 0..3 {
                    force[3 * n + a] += f1[3 * i + a] - f0[3 * i + a];
                }
            }
            change += e1 - e0;
        }
        Some(change)
    }

    #[inline]
    fn add_model_force(
        model: &dyn ForceModel,
        mesh: &TetMesh,
        t: usize,
        u: &[f64],
        force: &mut [f64],
    ) {
        let f = model.force(
            &mesh.element_of(t),
            &mesh.positions_of(t),
            &positions(mesh, t, u),
        );
        for (i, &n) in mesh.tets()[t].iter().enumerate() {
            for a in 0..3 {
                force[3 * n + a] += f[3 * i + a];
            }
        }
    }

    fn add_model_forces(
        mesh: &TetMesh,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) {
        add_in_blocks(mesh, u, force, |t, rest, x| {
            (models.model_of(t).force(&mesh.element_of(t), rest, x), 0.0)
        });
    }

    fn add_model_forces_and_energy(
        mesh: &TetMesh,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) -> f64 {
        add_in_blocks(mesh, u, force, |t, rest, x| {
            models
                .model_of(t)
                .force_and_energy(&mesh.element_of(t), rest, x)
        })
    }

    fn add_model_forces_and_energy_kept(
        mesh: &TetMesh,
        kept: &[Tet],
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        force: &mut [f64],
    ) -> f64 {
        let element = |t: usize, rest: &[Vector3<f64>; 4], x: &[Vector3<f64>; 4]| {
            models.model_of(t).force_and_energy(&kept[t], rest, x)
        };
        // Side by side where the first tet's model evaluates four at once (the others are
        // checked four by four).
        if mesh.tet_count() == 0 || !models.model_of(0).evaluates_four() {
            return add_in_blocks(mesh, u, force, element);
        }
        add_computed_in_blocks(mesh, force, |start, out| {
            use rayon::prelude::*;
            let batch = |(c, out): (usize, &mut [(Vector12, f64)])| {
                four_tets(mesh, kept, models, u, start + 4 * c, out)
            };
            // One thread: in this thread, not handed to the pool's (`one_thread` says why).
            match crate::linalg::parallel::one_thread() {
                true => out.chunks_mut(4).enumerate().for_each(batch),
                false => out.par_chunks_mut(4).enumerate().for_each(batch),
            }
        })
    }

    fn refill_model_tangent(
        mesh: &TetMesh,
        assembler: &Assembler,
        models: &(impl TetModels + ?Sized),
        u: &[f64],
        project: bool,
        tangent: &mut CscMatrix,
    ) -> Result<()> {
        let element = |t: usize| mesh.element_of(t);
        refill_tangent_of(mesh, element, assembler, models, (u, project), tangent)
    }

    fn refill_model_tangent_kept(
        mesh: &TetMesh,
        kept: &[Tet],
        assembler: &Assembler,
        models: &(impl TetModels + ?Sized),
        (u, project): (&[f64], bool),
        tangent: &mut CscMatrix,
    ) -> Result<()> {
        let element = |t: usize| kept[t];
        refill_tangent_of(mesh, element, assembler, models, (u, project), tangent)
    }

    fn model_cauchy_stress(
        model: &dyn ForceModel,
        mesh: &TetMesh,
        t: usize,
        u: &[f64],
    ) -> Matrix3<f64> {
        model.cauchy_stress(
            &mesh.element_of(t),
            &mesh.positions_of(t),
            &positions(mesh, t, u),
        )
    }

    fn mean_green_strain(mesh: &TetMesh, t: usize, u: &[f64]) -> Matrix3<f64> {
        let f = mesh
            .element_of(t)
            .deformation_gradient(&positions(mesh, t, u));
        (f.transpose() * f - Matrix3::identity()) * 0.5
    }
}

/// Refills `tangent` with Σₑ Kₑ of the 4-node tets, tet `t`'s rest element `element(t)`
/// (rebuilt from the nodes, or read from the kept ones), each Kₑ projected onto the positive
/// semi-definite cone when `project` is set.
fn refill_tangent_of(
    mesh: &TetMesh,
    element: impl Fn(usize) -> Tet + Sync,
    assembler: &Assembler,
    models: &(impl TetModels + ?Sized),
    (u, project): (&[f64], bool),
    tangent: &mut CscMatrix,
) -> Result<()> {
    assembler.reassemble_computing_once(
        mesh,
        |t| {
            let k = models.model_of(t).tangent(
                &element(t),
                &mesh.positions_of(t),
                &positions(mesh, t, u),
            );
            if project { project_psd(&k) } else { k }
        },
        tangent,
    )
}

/// Adds each 4-node tet's force (`element(t, rest, x)`'s first part) into the full vector
/// `force` at its nodes and returns the sum of the second parts (an energy, or 0). The tets are
/// computed in parallel a block at a time and added serially in tet order: the same sums, bit
/// for bit, as one tet after another, at a fraction of the time on several threads (a tet's
/// force, with the corotational model's polar decomposition, costs far more than adding it).
///
/// With one thread in rayon's pool the tets are computed in the calling thread
/// ([`one_thread`](crate::linalg::parallel::one_thread) says why: a pass over 5,880 tets takes
/// 0.5 ms, a parallel region's hand-over tens of µs). The same operations in the same order:
/// the same bits.
fn add_in_blocks(
    mesh: &TetMesh,
    u: &[f64],
    force: &mut [f64],
    element: impl Fn(usize, &[Vector3<f64>; 4], &[Vector3<f64>; 4]) -> (Vector12, f64) + Sync,
) -> f64 {
    use rayon::prelude::*;
    add_computed_in_blocks(mesh, force, |start, out| {
        let one = |(i, out): (usize, &mut (Vector12, f64))| {
            let t = start + i;
            let (rest, x) = corners(mesh, t, u);
            *out = element(t, &rest, &x);
        };
        match crate::linalg::parallel::one_thread() {
            true => out.iter_mut().enumerate().for_each(one),
            false => out.par_iter_mut().enumerate().for_each(one),
        }
    })
}

/// Tets `first..first + out.len()` (at most four) into `out`, each its force and energy at
/// `u` with its rest element from `kept`: the four side by side by their model's
/// [`ForceModel::force_and_energy_4`] when there are four, one model holds them all and it
/// [evaluates four](ForceModel::evaluates_four) at once (the same bits as one by one), else
/// one by one.
fn four_tets(
    mesh: &TetMesh,
    kept: &[Tet],
    models: &(impl TetModels + ?Sized),
    u: &[f64],
    first: usize,
    out: &mut [(Vector12, f64)],
) {
    let model = models.model_of(first);
    let one_model = model.evaluates_four()
        && (1..out.len()).all(|k| std::ptr::addr_eq(models.model_of(first + k), model));
    if let (Ok(four), true) = (<&mut [_; 4]>::try_from(&mut *out), one_model) {
        let mut rest = [[Vector3::zeros(); 4]; 4];
        let mut x = [[Vector3::zeros(); 4]; 4];
        for (k, (rest, x)) in rest.iter_mut().zip(&mut x).enumerate() {
            (*rest, *x) = corners(mesh, first + k, u);
        }
        let tets = [
            &kept[first],
            &kept[first + 1],
            &kept[first + 2],
            &kept[first + 3],
        ];
        model.force_and_energy_4(tets, &rest, &x, four);
        return;
    }
    for (k, out) in out.iter_mut().enumerate() {
        let t = first + k;
        let (rest, x) = corners(mesh, t, u);
        *out = models.model_of(t).force_and_energy(&kept[t], &rest, &x);
    }
}

/// Adds each 4-node tet's force (the first part of each entry `compute(start, block)` fills
/// for the tets `start..start + block.len()`) into the full vector `force` at its nodes and
/// returns the sum of the second parts (an energy, or 0), a block of tets at a time, added
/// serially in tet order whatever `compute` does in parallel.
fn add_computed_in_blocks(
    mesh: &TetMesh,
    force: &mut [f64],
    compute: impl Fn(usize, &mut [(Vector12, f64)]),
) -> f64 {
    // 8192 tets' forces (0.8 MB) stay in the cache between computing and adding them (a
    // multiple of four: each block's batches of four tets start at its first).
    const BLOCK: usize = 8192;
    let tets = mesh.tet_count();
    let mut block = vec![(Vector12::zeros(), 0.0); BLOCK.min(tets)];
    let mut total = 0.0;
    for start in (0..tets).step_by(BLOCK) {
        let end = (start + BLOCK).min(tets);
        compute(start, &mut block[..end - start]);
        for ((f, e), nodes) in block.iter().zip(&mesh.tets()[start..end]) {
            for (i, &n) in nodes.iter().enumerate() {
                for a in 0..3 {
                    force[3 * n + a] += f[3 * i + a];
                }
            }
            total += e;
        }
    }
    total
}
