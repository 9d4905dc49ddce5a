//! Parallel VTK output: each rank writes the piece of the tets it assembled (`.vtu`), rank 0
//! the `.pvtu` that lists the pieces and a one-frame `.pvd` collection, so that ParaView opens
//! the distributed result as one mesh.
//!
//! Files, for output folder `DIR` and stem `S` (the scene file's stem): `DIR/S_petsc.pvd`,
//! `DIR/S_petsc.pvtu`, `DIR/S_petsc/S_<rank>.vtu`; a dynamic run writes one frame per output
//! step, `DIR/S_petsc_<step>.pvtu` with `DIR/S_petsc/S_<step>_<rank>.vtu`, all listed with
//! their times in the `.pvd`. Each piece is written by the core's
//! [`VtuWriter`](tetfem::post::output::VtuWriter): appended raw binary by default (the scene's `output.vtu_format`), or ASCII with numbers in Rust's
//! shortest round-trip form; either way a reader gets the solver's f64 values back bit for bit.
//!
//! Each piece carries the arrays of the in-process run's `.vtu` for that analysis (a
//! [`FrameArrays`] of the whole mesh restricted to the piece: `displacement`, the stresses, von
//! Mises, principal stresses, `material_id`…, see [`tetfem::post::output`]'s frame docs), plus point
//! data `node` (`Int64`: the node's index in the mesh, to match pieces with the whole) and cell
//! data `rank` and `tet` (`Int64`: the tet's index in the mesh). Nodes on a boundary between
//! pieces appear in each piece that uses them (with equal values: nodal fields are the whole
//! mesh's).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use tetfem::TetMesh;
use tetfem::post::output::{FrameArrays, VtuFormat};

use crate::error::{Error, Result};

/// The files of a parallel output, for folder `directory` and stem `stem`: one frame (a static
/// solve) or one of several (a dynamic run, each frame named by its step).
#[derive(Debug, Clone, PartialEq)]
pub struct PvtuFiles {
    directory: PathBuf,
    stem: String,
    frame: Option<String>,
    format: VtuFormat,
}

impl PvtuFiles {
    /// The files of the one frame of a static solve.
    pub fn new(directory: &Path, stem: &str) -> Self {
        PvtuFiles {
            directory: directory.to_path_buf(),
            stem: stem.to_string(),
            frame: None,
            format: VtuFormat::default(),
        }
    }

    /// The files of the frame of step `step` of a dynamic run (`digits`: zero-padded width).
    pub fn frame(directory: &Path, stem: &str, step: usize, digits: usize) -> Self {
        PvtuFiles {
            directory: directory.to_path_buf(),
            stem: stem.to_string(),
            frame: Some(format!("{step:0digits$}")),
            format: VtuFormat::default(),
        }
    }

    /// The same files with the pieces encoded as `format` ([`VtuFormat::Binary`] unless told).
    pub fn with_format(mut self, format: VtuFormat) -> Self {
        self.format = format;
        self
    }

    /// The `.pvd` collection: `<stem>_petsc.pvd`.
    pub fn pvd(&self) -> PathBuf {
        self.directory.join(format!("{}_petsc.pvd", self.stem))
    }

    /// The `.pvtu` of this frame: `<stem>_petsc.pvtu` or `<stem>_petsc_<step>.pvtu`.
    pub fn pvtu(&self) -> PathBuf {
        self.directory.join(match &self.frame {
            Some(f) => format!("{}_petsc_{f}.pvtu", self.stem),
            None => format!("{}_petsc.pvtu", self.stem),
        })
    }

    /// The folder of the pieces: `<stem>_petsc`.
    pub fn pieces(&self) -> PathBuf {
        self.directory.join(format!("{}_petsc", self.stem))
    }

    /// The piece of rank `rank`.
    pub fn piece(&self, rank: usize) -> PathBuf {
        self.pieces().join(self.piece_name(rank))
    }

    fn piece_name(&self, rank: usize) -> String {
        match &self.frame {
            Some(f) => format!("{}_{f}_{rank}.vtu", self.stem),
            None => format!("{}_{rank}.vtu", self.stem),
        }
    }

    /// Writes the piece of rank `rank`: the tets `tets` of `mesh` with their nodes `nodes`
    /// (ascending mesh indices of every node of `tets`) and `arrays`, the frame's arrays
    /// restricted to them ([`FrameArrays::restrict`]: one tuple per entry of `nodes` and of
    /// `tets`), plus `node`, `rank` and `tet`. The encoding is this set of files' format.
    pub fn write_piece(
        &self,
        rank: usize,
        mesh: &TetMesh,
        tets: &[usize],
        nodes: &[usize],
        arrays: &FrameArrays,
    ) -> Result<PathBuf> {
        let local = |node: usize| {
            nodes.binary_search(&node).map_err(|_| {
                Error::invalid(
                    format!("node of the piece of rank {rank}"),
                    node,
                    "must be in the piece's node list",
                )
            })
        };
        let mut connectivity = Vec::with_capacity(tets.len());
        for &t in tets {
            let mut cell = [0usize; 4];
            for (local_node, &n) in cell.iter_mut().zip(&mesh.tets()[t]) {
                *local_node = local(n)?;
            }
            connectivity.push(cell);
        }
        // The piece as a mesh of its own (the global mesh's tets keep their orientation, so
        // the constructor's checks pass unchanged), written by the core's writer.
        let piece = TetMesh::new(
            nodes.iter().map(|&n| mesh.nodes()[n]).collect(),
            connectivity,
        )?;
        let node_ids: Vec<u64> = nodes.iter().map(|&n| n as u64).collect();
        let tet_ids: Vec<u64> = tets.iter().map(|&t| t as u64).collect();
        let ranks = vec![rank as u64; tets.len()];
        let path = self.piece(rank);
        arrays
            .writer(&piece)
            .map(|w| w.format(self.format))
            .and_then(|w| w.point_id_field("node", &node_ids))
            .and_then(|w| w.cell_id_field("rank", &ranks))
            .and_then(|w| w.cell_id_field("tet", &tet_ids))
            .and_then(|w| w.write(&path))?;
        Ok(path)
    }

    /// Writes the `.pvtu` listing the pieces of `ranks` ranks (rank 0 calls it), declaring the
    /// arrays of `arrays` (names, components, types: those of every piece) with `node`, `rank`
    /// and `tet`.
    pub fn write_pvtu(&self, ranks: usize, arrays: &FrameArrays) -> Result<PathBuf> {
        let pieces = self.pieces();
        let folder = pieces
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut text = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<PUnstructuredGrid GhostLevel=\"0\">\n",
        );
        if arrays.time.is_some() {
            text.push_str(
                "<PFieldData>\n<PDataArray type=\"Float64\" Name=\"TimeValue\"/>\n</PFieldData>\n",
            );
        }
        let declare = |text: &mut String, kind: &str, name: &str, components: usize| {
            let _ = writeln!(
                text,
                "<PDataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\"/>"
            );
        };
        text.push_str("<PPointData Vectors=\"displacement\">\n");
        for (name, components, _) in &arrays.point_fields {
            declare(&mut text, "Float64", name, *components);
        }
        for (name, _) in &arrays.point_ids {
            declare(&mut text, "Int64", name, 1);
        }
        declare(&mut text, "Int64", "node", 1);
        text.push_str("</PPointData>\n<PCellData>\n");
        for (name, components, _) in &arrays.cell_fields {
            declare(&mut text, "Float64", name, *components);
        }
        for (name, _) in &arrays.cell_ids {
            declare(&mut text, "Int64", name, 1);
        }
        for name in ["rank", "tet"] {
            declare(&mut text, "Int64", name, 1);
        }
        for (name, _) in &arrays.cell_indices {
            declare(&mut text, "Int32", name, 1);
        }
        text.push_str(
            "</PCellData>\n<PPoints>\n\
             <PDataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"/>\n</PPoints>\n",
        );
        for rank in 0..ranks {
            let _ = writeln!(
                text,
                "<Piece Source=\"{folder}/{}\"/>",
                self.piece_name(rank)
            );
        }
        text.push_str("</PUnstructuredGrid>\n</VTKFile>\n");
        let path = self.pvtu();
        write_file(&path, &text)?;
        Ok(path)
    }

    /// Writes the `.pvd` collection listing `frames` (time, `.pvtu` file) in order (rank 0;
    /// rewritten after each frame of a dynamic run, so that it is valid at any moment).
    pub fn write_pvd(&self, frames: &[(f64, PathBuf)]) -> Result<PathBuf> {
        let mut text = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<Collection>\n",
        );
        for (time, pvtu) in frames {
            let name = pvtu
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            let _ = writeln!(
                text,
                "<DataSet timestep=\"{time:e}\" group=\"\" part=\"0\" file=\"{name}\"/>"
            );
        }
        text.push_str("</Collection>\n</VTKFile>\n");
        let path = self.pvd();
        write_file(&path, &text)?;
        Ok(path)
    }
}

/// Writes `text` to `path` (creating its folder), whole: into a temporary file beside it, then
/// renamed, so a reader never sees half a file.
pub fn write_file(path: &Path, text: &str) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(io(dir))?;
    }
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(".tmp");
    let temporary = PathBuf::from(temporary);
    std::fs::write(&temporary, text).map_err(io(&temporary))?;
    std::fs::rename(&temporary, path).map_err(io(path))
}

/// The values of the array `name` of a piece this module wrote (either encoding), as f64 (the
/// `Int64` ids are below 2⁵³, so exact): for checks of a run's files without a VTK reader.
/// `None` if the array is missing or the file is not such a piece.
pub fn read_array(bytes: &[u8], name: &str) -> Option<Vec<f64>> {
    let text = String::from_utf8_lossy(bytes);
    let start = text.find(&format!("Name=\"{name}\""))?;
    let opening = text[..start].rfind("<DataArray")?;
    let tag = &text[opening..start + text[start..].find('>')?];
    let integer = tag.contains("type=\"Int64\"");
    if !tag.contains("format=\"appended\"") {
        let body = &text[opening + tag.len() + 1..];
        return body[..body.find("</DataArray>")?]
            .split_whitespace()
            .map(|v| v.parse().ok())
            .collect();
    }
    let offset: usize = tag
        .split("offset=\"")
        .nth(1)?
        .split('"')
        .next()?
        .parse()
        .ok()?;
    // The block starts after `<AppendedData encoding="raw">` and its `_`; each array is a
    // little-endian UInt64 byte count and its values.
    let marker = b"<AppendedData encoding=\"raw\">";
    let after = bytes.windows(marker.len()).position(|w| w == marker)? + marker.len();
    let data = after + bytes[after..].iter().position(|&b| b == b'_')? + 1;
    let block = bytes.get(data + offset..)?;
    let count = usize::try_from(u64::from_le_bytes(block.get(..8)?.try_into().ok()?)).ok()?;
    Some(
        block
            .get(8..8 + count)?
            .chunks_exact(8)
            .map(|c| {
                let word: [u8; 8] = c.try_into().unwrap_or_default();
                if integer {
                    i64::from_le_bytes(word) as f64
                } else {
                    f64::from_le_bytes(word)
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use tetfem::BoxSplit;

    #[test]
    fn a_piece_holds_its_tets_with_local_connectivity_and_exact_values() {
        let mesh = TetMesh::box_grid(
            [0.0, 0.0, 0.0].into(),
            [1.0, 1.0, 1.0].into(),
            [2, 1, 1],
            BoxSplit::Mirrored6,
        )
        .expect("a valid box");
        let tets = [1usize, 4];
        let mut nodes: Vec<usize> = tets.iter().flat_map(|&t| mesh.tets()[t]).collect();
        nodes.sort_unstable();
        nodes.dedup();
        // Values that need all 17 digits to round-trip.
        let displacement: Vec<f64> = (0..3 * nodes.len())
            .map(|i| (i as f64 + 0.1) / 3.0)
            .collect();
        let arrays = FrameArrays {
            point_fields: vec![("displacement".into(), 3, displacement.clone())],
            ..FrameArrays::default()
        };
        let dir = std::env::temp_dir().join(format!("tetfem-pvtu-unit-{}", std::process::id()));
        let expected_connectivity: Vec<f64> = tets
            .iter()
            .flat_map(|&t| mesh.tets()[t])
            .map(|n| nodes.binary_search(&n).expect("listed") as f64)
            .collect();
        // Binary is the default; ASCII by option. Both read back to the same bits.
        for format in [None, Some(VtuFormat::Ascii)] {
            let files = match format {
                None => PvtuFiles::new(&dir, "box"),
                Some(f) => PvtuFiles::new(&dir, "box").with_format(f),
            };
            let path = files
                .write_piece(1, &mesh, &tets, &nodes, &arrays)
                .expect("written");
            let bytes = std::fs::read(&path).expect("read back");
            let text = String::from_utf8_lossy(&bytes);
            assert_eq!(
                text.contains("<AppendedData"),
                format.is_none(),
                "binary unless ASCII is asked for"
            );
            assert!(text.contains(&format!(
                "NumberOfPoints=\"{}\" NumberOfCells=\"2\"",
                nodes.len()
            )));
            assert_eq!(
                read_array(&bytes, "displacement").expect("displacement"),
                displacement,
                "bit-exact round trip"
            );
            assert_eq!(
                read_array(&bytes, "connectivity").expect("connectivity"),
                expected_connectivity
            );
            assert_eq!(read_array(&bytes, "tet").expect("tet"), [1.0, 4.0]);
            assert_eq!(read_array(&bytes, "rank").expect("rank"), [1.0, 1.0]);
            let node_ids: Vec<f64> = nodes.iter().map(|&n| n as f64).collect();
            assert_eq!(read_array(&bytes, "node").expect("node"), node_ids);
        }
        let files = PvtuFiles::new(&dir, "box");
        let pvtu_path = files.write_pvtu(2, &arrays).expect("pvtu");
        let pvtu = std::fs::read_to_string(&pvtu_path).expect("pvtu");
        for name in ["displacement", "node", "rank", "tet"] {
            assert!(
                pvtu.contains(&format!("Name=\"{name}\"")),
                "{name} declared"
            );
        }
        assert!(pvtu.contains("Source=\"box_petsc/box_0.vtu\""));
        assert!(pvtu.contains("Source=\"box_petsc/box_1.vtu\""));
        let pvd = std::fs::read_to_string(files.write_pvd(&[(0.0, pvtu_path)]).expect("pvd"))
            .expect("pvd");
        assert!(pvd.contains("file=\"box_petsc.pvtu\""));
        // A frame of a dynamic run: its own .pvtu and piece names, the same folder and .pvd.
        let frame = PvtuFiles::frame(&dir, "box", 7, 4);
        assert_eq!(frame.pvtu(), dir.join("box_petsc_0007.pvtu"));
        assert_eq!(frame.piece(1), dir.join("box_petsc/box_0007_1.vtu"));
        assert_eq!(frame.pvd(), files.pvd());
    }

    #[test]
    fn a_node_outside_the_piece_is_named() {
        let mesh = TetMesh::box_grid(
            [0.0, 0.0, 0.0].into(),
            [1.0, 1.0, 1.0].into(),
            [1, 1, 1],
            BoxSplit::Mirrored6,
        )
        .expect("a valid box");
        let dir = std::env::temp_dir().join(format!("tetfem-pvtu-unit-bad-{}", std::process::id()));
        let message = PvtuFiles::new(&dir, "b")
            .write_piece(
                0,
                &mesh,
                &[0],
                &[0],
                &FrameArrays {
                    point_fields: vec![("displacement".into(), 3, vec![0.0; 3])],
                    ..FrameArrays::default()
                },
            )
            .expect_err("tet 0 has nodes beyond node 0")
            .to_string();
        assert!(
            message.contains("must be in the piece's node list"),
            "{message}"
        );
    }
}
