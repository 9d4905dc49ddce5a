//! Materials per region: every tet has one [`Material`], chosen from a short list.
//!
//! A [`MaterialMap`] holds the distinct materials and, for each tet, the index of its material.
//! It is built from Gmsh physical volumes, TetGen region attributes, boxes or any predicate over
//! tet centroids with a [`MaterialAssignment`], which rejects a tet that two selections claim
//! and (unless a default covers the rest) a tet that none claims, naming the tet.
//!
//! Every function of tetfem that takes a material per element takes `&impl TetMaterials`: a
//! single [`Material`] is the uniform case (the same arithmetic, bit for bit, as before maps
//! existed) and a [`MaterialMap`] the per-region one.
//!
//! Units are the materials' own (Pa for E, kg/m³ for ρ in SI); selection boxes and centroids
//! are in the mesh's length unit.

use nalgebra::Vector3;

use crate::base::error::{Error, Result};
use crate::fe::material::Material;
use crate::mesh::io::ImportedMesh;
use crate::mesh::{CellType, TetMesh};

/// The material of each tet: the common interface of a single [`Material`] (every tet the
/// same) and a [`MaterialMap`].
pub trait TetMaterials: Sync {
    /// The distinct materials (at least one).
    fn material_list(&self) -> &[Material];
    /// The index into [`material_list`](Self::material_list) of tet `tet`'s material. Callers
    /// check [`check_tet_count`](Self::check_tet_count) first; for a map, a tet beyond its count
    /// panics.
    fn index_of(&self, tet: usize) -> usize;
    /// An error unless these materials cover exactly `tet_count` tets (always `Ok` for a
    /// single material).
    fn check_covers(&self, tet_count: usize) -> Result<()>;

    /// An error unless these materials cover exactly the tets of `mesh`, of any cell type
    /// (always `Ok` for a single material).
    fn check_tet_count<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<()>
    where
        Self: Sized,
    {
        self.check_covers(mesh.tet_count())
    }

    /// The material of tet `tet` (see [`index_of`](Self::index_of)).
    fn material_of(&self, tet: usize) -> &Material {
        &self.material_list()[self.index_of(tet)]
    }
}

impl TetMaterials for Material {
    fn material_list(&self) -> &[Material] {
        std::slice::from_ref(self)
    }

    #[inline(always)]
    fn index_of(&self, _tet: usize) -> usize {
        0
    }

    fn check_covers(&self, _tet_count: usize) -> Result<()> {
        Ok(())
    }
}

impl<T: TetMaterials + ?Sized> TetMaterials for &T {
    fn material_list(&self) -> &[Material] {
        (**self).material_list()
    }

    #[inline(always)]
    fn index_of(&self, tet: usize) -> usize {
        (**self).index_of(tet)
    }

    fn check_covers(&self, tet_count: usize) -> Result<()> {
        (**self).check_covers(tet_count)
    }
}

/// Distinct materials, their names, and the material index of every tet.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialMap {
    materials: Vec<Material>,
    names: Vec<String>,
    of_tet: Vec<u32>,
}

impl MaterialMap {
    /// Every one of `tet_count` tets made of `material` (named `"material"`).
    pub fn uniform(material: Material, tet_count: usize) -> Self {
        MaterialMap {
            materials: vec![material],
            names: vec!["material".into()],
            of_tet: vec![0; tet_count],
        }
    }

    /// A map from its parts: `materials[of_tet[t]]` is the material of tet t, `names` one per
    /// material (for messages).
    ///
    /// Errors: no material, `names` not one per material, more than `u32::MAX` materials, or an
    /// index out of range (naming the tet).
    pub fn new(materials: Vec<Material>, names: Vec<String>, of_tet: Vec<u32>) -> Result<Self> {
        if materials.is_empty() || materials.len() >= u32::MAX as usize {
            return Err(Error::invalid_parameter(
                "materials",
                format!("{} materials", materials.len()),
                "need at least one (and fewer than 2³² − 1)",
            ));
        }
        Error::check_len("material names", materials.len(), names.len())?;
        if let Some(t) = of_tet.iter().position(|&i| i as usize >= materials.len()) {
            return Err(Error::invalid_parameter(
                format!("material index of tet {t}"),
                of_tet[t],
                format!("must be below the material count {}", materials.len()),
            ));
        }
        Ok(MaterialMap {
            materials,
            names,
            of_tet,
        })
    }

    /// One material per Gmsh physical volume (dim-3 group, by name or tag): `table` lists
    /// (group, material) pairs; `default` covers the tets no listed group holds.
    ///
    /// Errors: a name that is no volume group of the file, a tet in two listed groups, or (with
    /// no default) a tet in none, each naming the tet and the groups.
    pub fn from_gmsh_volumes<C: CellType>(
        imported: &ImportedMesh<C>,
        table: &[(&str, Material)],
        default: Option<Material>,
    ) -> Result<Self> {
        let mut assignment = MaterialAssignment::new(imported.mesh.tet_count());
        for (key, material) in table {
            let tets = volume_group_tets(imported, key)?;
            assignment.assign(format!("group '{key}'"), *material, tets.iter().copied())?;
        }
        assignment.finish(default)
    }

    /// One material per TetGen region attribute (the first attribute of each tet in the `.ele`
    /// file): `table` lists (attribute value, material) pairs, matched exactly (region
    /// attributes are whole numbers written as floats); `default` covers the rest.
    ///
    /// Errors: the file has no tet attributes, a tet claimed twice (the same value listed
    /// twice) or, with no default, a tet whose attribute is not listed, naming the tet.
    pub fn from_tetgen_regions<C: CellType>(
        imported: &ImportedMesh<C>,
        table: &[(f64, Material)],
        default: Option<Material>,
    ) -> Result<Self> {
        let mut assignment = MaterialAssignment::new(imported.mesh.tet_count());
        for (value, material) in table {
            let tets = attribute_tets(imported, *value)?;
            assignment.assign(format!("region attribute {value}"), *material, tets)?;
        }
        assignment.finish(default)
    }

    /// The distinct materials.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The largest Young's modulus among the materials (Pa; 0 for none): the scale of the
    /// contact barriers' default stiffness, which must hold the stiffest surface.
    pub fn stiffest_youngs_modulus(&self) -> f64 {
        self.materials
            .iter()
            .map(|m| m.youngs_modulus())
            .fold(0.0, f64::max)
    }

    /// The name of each material (for messages: `"group 'steel'"`, `"materials[1]"`, …).
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The material index of every tet.
    pub fn of_tet(&self) -> &[u32] {
        &self.of_tet
    }

    /// Number of tets.
    pub fn tet_count(&self) -> usize {
        self.of_tet.len()
    }

    /// Number of tets of each material.
    pub fn counts(&self) -> Vec<usize> {
        let mut counts = vec![0; self.materials.len()];
        for &i in &self.of_tet {
            counts[i as usize] += 1;
        }
        counts
    }

    /// Warnings of every material ([`Material::warnings`]), each once.
    pub fn warnings(&self) -> Vec<crate::base::warning::Warning> {
        let mut warnings = Vec::new();
        for m in &self.materials {
            for w in m.warnings() {
                if !warnings.contains(&w) {
                    warnings.push(w);
                }
            }
        }
        warnings
    }
}

impl TetMaterials for MaterialMap {
    fn material_list(&self) -> &[Material] {
        &self.materials
    }

    #[inline(always)]
    fn index_of(&self, tet: usize) -> usize {
        self.of_tet[tet] as usize
    }

    fn check_covers(&self, tet_count: usize) -> Result<()> {
        if self.of_tet.len() != tet_count {
            return Err(Error::invalid_parameter(
                "material map",
                format!("{} tets", self.of_tet.len()),
                format!("must give a material to each of the mesh's {tet_count} tets"),
            ));
        }
        Ok(())
    }
}

/// Claims tets for materials one selection at a time, then checks that every tet was claimed
/// exactly once ([`finish`](Self::finish)).
#[derive(Debug, Clone)]
pub struct MaterialAssignment {
    materials: Vec<Material>,
    names: Vec<String>,
    /// The claiming material's index per tet, [`UNCLAIMED`] if none yet.
    claims: Vec<u32>,
}

const UNCLAIMED: u32 = u32::MAX;

impl MaterialAssignment {
    /// No tet of `tet_count` claimed yet.
    pub fn new(tet_count: usize) -> Self {
        MaterialAssignment {
            materials: Vec::new(),
            names: Vec::new(),
            claims: vec![UNCLAIMED; tet_count],
        }
    }

    /// `tets` are made of `material`; `name` identifies the selection in messages. Returns
    /// the number of tets claimed.
    ///
    /// Errors: a tet index out of range, or a tet that an earlier selection claimed (naming
    /// the tet and both selections). On error nothing of this selection is kept.
    pub fn assign(
        &mut self,
        name: impl Into<String>,
        material: Material,
        tets: impl IntoIterator<Item = usize>,
    ) -> Result<usize> {
        let name = name.into();
        if self.materials.len() >= (UNCLAIMED - 1) as usize {
            return Err(Error::invalid_parameter(
                "material selections",
                self.materials.len(),
                "at most 2³² − 2",
            ));
        }
        let index = self.materials.len() as u32;
        let mut claimed = Vec::new();
        for t in tets {
            let result = match self.claims.get(t) {
                None => Err(Error::invalid_parameter(
                    format!("tet {t} of {name}"),
                    t,
                    format!("must be below the tet count {}", self.claims.len()),
                )),
                Some(&UNCLAIMED) => Ok(()),
                Some(&i) if i == index => Ok(()),
                Some(&i) => Err(Error::invalid_parameter(
                    format!("tet {t}"),
                    format!("claimed by {} and by {name}", self.names[i as usize]),
                    "each tet takes one material: make the selections disjoint",
                )),
            };
            if let Err(e) = result {
                for &c in &claimed {
                    self.claims[c] = UNCLAIMED;
                }
                return Err(e);
            }
            if self.claims[t] == UNCLAIMED {
                self.claims[t] = index;
                claimed.push(t);
            }
        }
        self.materials.push(material);
        self.names.push(name);
        Ok(claimed.len())
    }

    /// Claims for `material` every tet whose centroid (the mean of its four corners, length
    /// units) satisfies `inside`; returns the number claimed. Errors as [`assign`](Self::assign),
    /// or `mesh` has another tet count.
    pub fn assign_where<C: CellType>(
        &mut self,
        mesh: &TetMesh<C>,
        name: impl Into<String>,
        material: Material,
        inside: impl Fn(&Vector3<f64>) -> bool,
    ) -> Result<usize> {
        self.check_mesh(mesh)?;
        let tets: Vec<usize> = (0..mesh.tet_count())
            .filter(|&t| inside(&centroid(mesh, t)))
            .collect();
        self.assign(name, material, tets)
    }

    /// Claims for `material` every tet whose centroid lies in the closed box [`min`, `max`]
    /// (length units); returns the number claimed.
    ///
    /// A box boundary on a mesh plane splits the tets exactly there (every tet lies on one side
    /// of a mesh plane, and its centroid strictly inside that side).
    pub fn assign_box<C: CellType>(
        &mut self,
        mesh: &TetMesh<C>,
        name: impl Into<String>,
        material: Material,
        min: Vector3<f64>,
        max: Vector3<f64>,
    ) -> Result<usize> {
        if !(0..3).all(|a| min[a].is_finite() && max[a].is_finite() && min[a] <= max[a]) {
            return Err(Error::invalid_parameter(
                "material box",
                format!("min {:?}, max {:?}", min.as_slice(), max.as_slice()),
                "needs finite corners with min ≤ max on every axis",
            ));
        }
        self.assign_where(mesh, name, material, |c| {
            (0..3).all(|a| c[a] >= min[a] && c[a] <= max[a])
        })
    }

    /// The map: `default` (if given, named `"the default material"`) for every tet no
    /// selection claimed.
    ///
    /// Errors: with no default, a tet no selection claimed, naming it and how many others are
    /// unclaimed; no material at all.
    pub fn finish(self, default: Option<Material>) -> Result<MaterialMap> {
        let MaterialAssignment {
            mut materials,
            mut names,
            mut claims,
        } = self;
        let unclaimed: Vec<usize> = (0..claims.len())
            .filter(|&t| claims[t] == UNCLAIMED)
            .collect();
        if !unclaimed.is_empty() {
            let Some(default) = default else {
                let others = match unclaimed.len() - 1 {
                    0 => String::new(),
                    n => format!(" (and {n} other tets)"),
                };
                return Err(Error::invalid_parameter(
                    format!("tet {}", unclaimed[0]),
                    format!("no material{others}"),
                    "every tet needs a material: extend the selections or give a default material",
                ));
            };
            let index = materials.len() as u32;
            materials.push(default);
            names.push("the default material".into());
            for t in unclaimed {
                claims[t] = index;
            }
        }
        if materials.is_empty() {
            // No tet and no selection: a map of no tets still needs its one material list.
            match default {
                Some(d) => {
                    materials.push(d);
                    names.push("the default material".into());
                }
                None => {
                    return Err(Error::invalid_parameter(
                        "materials",
                        "none",
                        "need at least one material",
                    ));
                }
            }
        }
        MaterialMap::new(materials, names, claims)
    }

    fn check_mesh<C: CellType>(&self, mesh: &TetMesh<C>) -> Result<()> {
        if mesh.tet_count() != self.claims.len() {
            return Err(Error::invalid_parameter(
                "mesh",
                format!("{} tets", mesh.tet_count()),
                format!("must have the assignment's {} tets", self.claims.len()),
            ));
        }
        Ok(())
    }
}

/// The centroid (mean of the four corners) of tet `t`, which the caller checked exists.
fn centroid<C: CellType>(mesh: &TetMesh<C>, t: usize) -> Vector3<f64> {
    let x = mesh.corner_positions_of(t);
    (x[0] + x[1] + x[2] + x[3]) / 4.0
}

/// The tets of the Gmsh physical volume named `key` (or with tag `key`).
pub fn volume_group_tets<'a, C: CellType>(
    imported: &'a ImportedMesh<C>,
    key: &str,
) -> Result<&'a [usize]> {
    let tag: Option<i32> = key.trim().parse().ok();
    imported
        .groups
        .iter()
        .filter(|g| g.dim == 3)
        .find(|g| g.name.as_deref() == Some(key))
        .or_else(|| {
            imported
                .groups
                .iter()
                .find(|g| g.dim == 3 && Some(g.tag) == tag)
        })
        .map(|g| g.tets.as_slice())
        .ok_or_else(|| {
            let known: Vec<String> = imported
                .groups
                .iter()
                .filter(|g| g.dim == 3)
                .map(|g| g.label())
                .collect();
            Error::invalid_parameter(
                "volume group",
                key,
                format!(
                    "must name a physical volume of the mesh (it has: {})",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
}

/// The tets whose TetGen region attribute equals `value`.
pub fn attribute_tets<C: CellType>(imported: &ImportedMesh<C>, value: f64) -> Result<Vec<usize>> {
    let Some(attributes) = &imported.tet_attributes else {
        return Err(Error::invalid_parameter(
            "region attribute",
            value,
            "needs a TetGen mesh whose .ele file has tet attributes",
        ));
    };
    Ok((0..attributes.len())
        .filter(|&t| attributes[t] == value)
        .collect())
}
