//! ParaView collection (`.pvd`): a list of `.vtu` frames with their times, so that ParaView
//! opens a run as an animation.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::write_atomically;
use crate::base::error::{Error, Result};

/// A `.pvd` file that grows by one frame at a time.
///
/// [`PvdCollection::push`] rewrites the whole (small) file atomically after each frame, so an
/// interrupted run leaves a valid collection of the frames completed.
#[derive(Debug, Clone, PartialEq)]
pub struct PvdCollection {
    path: PathBuf,
    frames: Vec<(f64, String)>,
}

impl PvdCollection {
    /// An empty collection to be written at `path` (nothing is written until the first push).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        PvdCollection {
            path: path.into(),
            frames: Vec::new(),
        }
    }

    /// Reads a collection this type wrote (one `<DataSet timestep=".." .. file=".."/>` line per
    /// frame), to continue it. Errors: the file cannot be read ([`Error::Io`]), a frame line
    /// without a readable time or file ([`Error::Parse`] naming its line).
    pub fn read(path: impl Into<PathBuf>) -> Result<Self> {
        let path = path.into();
        let text =
            crate::base::input_file::read_regular_text(&path, "a ParaView collection (.pvd)")?;
        let mut frames = Vec::new();
        for (i, line) in text.lines().enumerate() {
            if !line.trim_start().starts_with("<DataSet") {
                continue;
            }
            let frame = attribute(line, "timestep")
                .and_then(|t| t.parse::<f64>().ok())
                .zip(attribute(line, "file").map(xml_unescape));
            match frame {
                Some(frame) => frames.push(frame),
                None => {
                    return Err(Error::Parse {
                        path,
                        line: i + 1,
                        message: "a DataSet without a numeric timestep and a file".into(),
                    });
                }
            }
        }
        Ok(PvdCollection { path, frames })
    }

    /// Keeps the frames for which `keep(time, file)` holds (in order), returns the files of the
    /// others; the file is rewritten on the next [`push`](Self::push) or [`write`](Self::write).
    pub fn retain(&mut self, mut keep: impl FnMut(f64, &str) -> bool) -> Vec<String> {
        let (kept, dropped): (Vec<_>, Vec<_>) = std::mem::take(&mut self.frames)
            .into_iter()
            .partition(|(t, f)| keep(*t, f));
        self.frames = kept;
        dropped.into_iter().map(|(_, f)| f).collect()
    }

    /// The collection's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Frames so far: (time, file name relative to the collection's folder).
    pub fn frames(&self) -> &[(f64, String)] {
        &self.frames
    }

    /// Adds the frame `vtu` (a file in the collection's folder or below it) at `time` (time
    /// units) and rewrites the collection. Times must be finite and non-decreasing.
    pub fn push(&mut self, time: f64, vtu: &Path) -> Result<()> {
        if !time.is_finite() || self.frames.last().is_some_and(|(t, _)| time < *t) {
            return Err(Error::invalid_parameter(
                "frame time",
                time,
                "must be finite and not before the previous frame",
            ));
        }
        let dir = self.path.parent().unwrap_or(Path::new(""));
        let relative = vtu.strip_prefix(dir).unwrap_or(vtu);
        let name = relative.to_string_lossy().replace('\\', "/");
        self.frames.push((time, name));
        self.write()
    }

    /// Writes the collection (atomically).
    pub fn write(&self) -> Result<()> {
        write_atomically(&self.path, |out: &mut dyn Write| {
            writeln!(out, r#"<?xml version="1.0"?>"#)?;
            writeln!(
                out,
                r#"<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">"#
            )?;
            writeln!(out, "  <Collection>")?;
            for (time, file) in &self.frames {
                writeln!(
                    out,
                    r#"    <DataSet timestep="{time:e}" group="" part="0" file="{}"/>"#,
                    xml_attribute(file)
                )?;
            }
            writeln!(out, "  </Collection>")?;
            writeln!(out, "</VTKFile>")
        })
    }
}

fn xml_attribute(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn xml_unescape(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&gt;", ">")
        .replace("&lt;", "<")
        .replace("&amp;", "&")
}

/// The value of `name="…"` in an XML line (as [`xml_attribute`] wrote it: no `"` inside).
fn attribute<'a>(line: &'a str, name: &str) -> Option<&'a str> {
    let start = line.find(&format!(" {name}=\""))? + name.len() + 3;
    let end = line[start..].find('"')?;
    Some(&line[start..start + end])
}
