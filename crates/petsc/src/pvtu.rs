//! Parallel VTK output: each rank writes the piece of the tets it assembled (`.vtu`), rank 0
//! the `.pvtu` that lists the pieces and a one-frame `.pvd` collection, so that ParaView opens
//! the distributed result as one mesh.
//!
//! Files, for output folder `DIR` and stem `S` (the scene file's stem): `DIR/S_petsc.pvd`,
//! `DIR/S_petsc.pvtu`, `DIR/S_petsc/S_<rank>.vtu`; a dynamic run writes one frame per output
//! step, `DIR/S_petsc_<step>.pvtu` with `DIR/S_petsc/S_<step>_<rank>.vtu`, all listed with
//! their times in the `.pvd`. ASCII XML; numbers printed with Rust's
//! shortest round-trip form, so a reader gets the solver's f64 values back bit for bit.
//!
//! Point data: `displacement` (m, 3 components) and `node` (the node's index in the mesh, to
//! match pieces with the whole); cell data: `rank` and `tet` (the tet's index in the mesh).
//! Nodes on a boundary between pieces appear in each piece that uses them (with equal values).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use tetfem::TetMesh;

use crate::error::{Error, Result};

/// The files of a parallel output, for folder `directory` and stem `stem`: one frame (a static
/// solve) or one of several (a dynamic run, each frame named by its step).
#[derive(Debug, Clone, PartialEq)]
pub struct PvtuFiles {
    directory: PathBuf,
    stem: String,
    frame: Option<String>,
}

impl PvtuFiles {
    /// The files of the one frame of a static solve.
    pub fn new(directory: &Path, stem: &str) -> Self {
        PvtuFiles {
            directory: directory.to_path_buf(),
            stem: stem.to_string(),
            frame: None,
        }
    }

    /// The files of the frame of step `step` of a dynamic run (`digits`: zero-padded width).
    pub fn frame(directory: &Path, stem: &str, step: usize, digits: usize) -> Self {
        PvtuFiles {
            directory: directory.to_path_buf(),
            stem: stem.to_string(),
            frame: Some(format!("{step:0digits$}")),
        }
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

    /// Writes the piece of rank `rank`: the tets `tets` of `mesh`, with the displacement of
    /// their nodes, `nodes` (ascending mesh indices of every node of `tets`) and
    /// `displacement` (3 per entry of `nodes`).
    pub fn write_piece(
        &self,
        rank: usize,
        mesh: &TetMesh,
        tets: &[usize],
        nodes: &[usize],
        displacement: &[f64],
    ) -> Result<PathBuf> {
        if displacement.len() != 3 * nodes.len() {
            return Err(Error::invalid(
                "piece displacement values",
                displacement.len(),
                format!("must be 3 per node ({} nodes)", nodes.len()),
            ));
        }
        let local = |node: usize| {
            nodes.binary_search(&node).map_err(|_| {
                Error::invalid(
                    format!("node of the piece of rank {rank}"),
                    node,
                    "must be in the piece's node list",
                )
            })
        };
        let mut text = String::new();
        let _ = writeln!(
            text,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" \
             NumberOfCells=\"{}\">",
            nodes.len(),
            tets.len()
        );
        text.push_str("<PointData Vectors=\"displacement\">\n");
        array(
            &mut text,
            "Float64",
            "displacement",
            3,
            displacement.iter().map(|v| format!("{v:e}")),
        );
        array(
            &mut text,
            "Int64",
            "node",
            1,
            nodes.iter().map(usize::to_string),
        );
        text.push_str("</PointData>\n<CellData>\n");
        array(
            &mut text,
            "Int32",
            "rank",
            1,
            tets.iter().map(|_| rank.to_string()),
        );
        array(
            &mut text,
            "Int64",
            "tet",
            1,
            tets.iter().map(usize::to_string),
        );
        text.push_str("</CellData>\n<Points>\n");
        array(
            &mut text,
            "Float64",
            "Points",
            3,
            nodes
                .iter()
                .flat_map(|&n| mesh.nodes()[n].iter().copied().collect::<Vec<_>>())
                .map(|v| format!("{v:e}")),
        );
        text.push_str("</Points>\n<Cells>\n");
        let mut connectivity = Vec::with_capacity(4 * tets.len());
        for &t in tets {
            for &n in &mesh.tets()[t] {
                connectivity.push(local(n)?.to_string());
            }
        }
        array(
            &mut text,
            "Int64",
            "connectivity",
            1,
            connectivity.into_iter(),
        );
        array(
            &mut text,
            "Int64",
            "offsets",
            1,
            (1..=tets.len()).map(|i| (4 * i).to_string()),
        );
        // VTK_TETRA = 10.
        array(
            &mut text,
            "UInt8",
            "types",
            1,
            tets.iter().map(|_| "10".to_string()),
        );
        text.push_str("</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
        let path = self.piece(rank);
        write_file(&path, &text)?;
        Ok(path)
    }

    /// Writes the `.pvtu` listing the pieces of `ranks` ranks (rank 0 calls it).
    pub fn write_pvtu(&self, ranks: usize) -> Result<PathBuf> {
        let pieces = self.pieces();
        let folder = pieces
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut text = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"0.1\" \
             byte_order=\"LittleEndian\">\n<PUnstructuredGrid GhostLevel=\"0\">\n\
             <PPointData Vectors=\"displacement\">\n\
             <PDataArray type=\"Float64\" Name=\"displacement\" NumberOfComponents=\"3\"/>\n\
             <PDataArray type=\"Int64\" Name=\"node\"/>\n</PPointData>\n<PCellData>\n\
             <PDataArray type=\"Int32\" Name=\"rank\"/>\n<PDataArray type=\"Int64\" Name=\"tet\"/>\n\
             </PCellData>\n<PPoints>\n\
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

fn array(
    text: &mut String,
    kind: &str,
    name: &str,
    components: usize,
    values: impl Iterator<Item = String>,
) {
    let _ = writeln!(
        text,
        "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"ascii\">"
    );
    for (i, v) in values.enumerate() {
        text.push_str(&v);
        text.push(if (i + 1) % (3 * components.max(1)) == 0 {
            '\n'
        } else {
            ' '
        });
    }
    text.push_str("\n</DataArray>\n");
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
        let dir = std::env::temp_dir().join(format!("tetfem-pvtu-unit-{}", std::process::id()));
        let files = PvtuFiles::new(&dir, "box");
        let path = files
            .write_piece(1, &mesh, &tets, &nodes, &displacement)
            .expect("written");
        let text = std::fs::read_to_string(&path).expect("read back");
        assert!(text.contains(&format!(
            "NumberOfPoints=\"{}\" NumberOfCells=\"2\"",
            nodes.len()
        )));
        let block = |name: &str| -> Vec<String> {
            let start = text
                .find(&format!("Name=\"{name}\""))
                .expect("array present");
            let body = &text[start..];
            let body = &body[body.find('>').expect("tag end") + 1..];
            body[..body.find("</DataArray>").expect("array end")]
                .split_whitespace()
                .map(str::to_string)
                .collect()
        };
        let read: Vec<f64> = block("displacement")
            .iter()
            .map(|v| v.parse().expect("number"))
            .collect();
        assert_eq!(read, displacement, "bit-exact round trip");
        let connectivity: Vec<usize> = block("connectivity")
            .iter()
            .map(|v| v.parse().expect("index"))
            .collect();
        let expected: Vec<usize> = tets
            .iter()
            .flat_map(|&t| mesh.tets()[t])
            .map(|n| nodes.binary_search(&n).expect("listed"))
            .collect();
        assert_eq!(connectivity, expected);
        assert_eq!(block("tet"), ["1", "4"]);
        assert_eq!(block("types"), ["10", "10"]);
        let pvtu_path = files.write_pvtu(2).expect("pvtu");
        let pvtu = std::fs::read_to_string(&pvtu_path).expect("pvtu");
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
            .write_piece(0, &mesh, &[0], &[0], &[0.0; 3])
            .expect_err("tet 0 has nodes beyond node 0")
            .to_string();
        assert!(
            message.contains("must be in the piece's node list"),
            "{message}"
        );
    }
}
