//! The node tags of an MSH 4.1 `$Nodes` section, read by us rather than taken from `mshio`.
//!
//! mshio 0.4 keeps a block's tags only when the section's tags are "sparse" (max − min ≥ count);
//! when they fill one contiguous range it drops them, as if every block listed its tags in
//! ascending order from the smallest. Valid files list them in any order (Gmsh writes tags in
//! entity order; renumbered or merged files permute them), so the tags are read here, with the
//! line of each, and the coordinates still come from mshio (checked to be the same blocks).
//!
//! Layout (Gmsh reference manual, MSH 4.1): a header `<blocks> <nodes> <min tag> <max tag>`,
//! then per block `<entity dim> <entity tag> <parametric> <nodes in block>`, the block's tags,
//! then its coordinates. In binary files the counts and tags are size_t of `size` bytes, the
//! three block ints 4 bytes and the coordinates 8-byte doubles, in the byte order of the file.
//!
//! mshio gives no positions for elements either: [`element_line`] finds the line of one element
//! of the `$Elements` section (header `<blocks> <elements> <min tag> <max tag>`, per block
//! `<entity dim> <entity tag> <element type> <elements in block>`, then per element its tag and
//! node tags, all size_t in binary files but the three block ints), for errors that name it.

use std::path::Path;

use super::text::line_of_offset;
use crate::error::{Error, Result};

/// One node tag and the 1-based file line it is on (for binary data, the line count up to its
/// byte offset).
pub(crate) type TagAt = (u64, usize);

/// How the numbers of the section are stored.
#[derive(Clone, Copy)]
pub(crate) enum Encoding {
    /// Whitespace-separated text.
    Ascii,
    /// size_t of `size` bytes, in little- or big-endian byte order.
    Binary { size: usize, little_endian: bool },
}

/// The tags of every node block of the `$Nodes` section that starts at byte `start` (just after
/// the `$Nodes` line), in file order.
pub(crate) fn node_tags(
    path: &Path,
    bytes: &[u8],
    start: usize,
    encoding: Encoding,
) -> Result<Vec<Vec<TagAt>>> {
    let mut cursor = Cursor::new(path, bytes, start, encoding);
    let blocks = cursor.size_t("the number of node blocks")?;
    let _nodes = cursor.size_t("the number of nodes")?;
    let _min = cursor.size_t("the smallest node tag")?;
    let _max = cursor.size_t("the largest node tag")?;
    let mut out = Vec::new();
    // No reservation from the claimed counts: every block and tag consumes input, so the
    // vectors grow only as far as the file's bytes justify.
    for _ in 0..blocks {
        cursor.int("entity dimension")?;
        cursor.int("entity tag")?;
        let parametric = cursor.int("parametric flag")?;
        let count = cursor.size_t("the number of nodes in the block")?;
        let mut tags = Vec::new();
        for _ in 0..count {
            let line = cursor.line();
            tags.push((cursor.size_t("a node tag")?, line));
        }
        // x y z, plus u (and v) for parametric nodes on curves (surfaces); mshio rejects
        // parametric blocks before this result is used, so the count only has to advance.
        let per_node = if parametric == 0 { 3 } else { 5 };
        for _ in 0..count.saturating_mul(per_node) {
            cursor.double("a node coordinate")?;
        }
        out.push(tags);
    }
    Ok(out)
}

/// The 1-based line of element number `element` (0-based, in file order) of block `block` of
/// the `$Elements` section that starts at byte `start` (just after the `$Elements` line), if the
/// section reads as mshio read it: `layout` gives per block its element count and the nodes per
/// element, and the element found must have the tag `tag`. `None` when it does not (the caller
/// then names the section's line). For binary data the line is the line count up to the
/// element's byte offset. Reads the section up to the element: for error messages only.
#[allow(clippy::too_many_arguments)]
pub(crate) fn element_line(
    path: &Path,
    bytes: &[u8],
    start: usize,
    encoding: Encoding,
    layout: &[(usize, usize)],
    block: usize,
    element: usize,
    tag: u64,
) -> Option<usize> {
    let mut cursor = Cursor::new(path, bytes, start, encoding);
    let size_t = |c: &mut Cursor| c.size_t("").ok();
    for _ in 0..4 {
        size_t(&mut cursor)?;
    }
    for (b, &(count, nodes)) in layout.iter().enumerate().take(block + 1) {
        for _ in 0..3 {
            cursor.int("").ok()?;
        }
        if size_t(&mut cursor)? != count as u64 {
            return None;
        }
        let skipped = if b == block { element } else { count };
        for _ in 0..skipped.checked_mul(nodes + 1)? {
            size_t(&mut cursor)?;
        }
    }
    let line = cursor.line();
    (size_t(&mut cursor)? == tag).then_some(line)
}

struct Cursor<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
    encoding: Encoding,
    /// A byte offset and its line, so that successive [`line`](Self::line) calls count only
    /// the newlines in between (counting from the file's start each time made reading n tags
    /// O(n × file size)).
    known: std::cell::Cell<(usize, usize)>,
}

impl<'a> Cursor<'a> {
    fn new(path: &'a Path, bytes: &'a [u8], start: usize, encoding: Encoding) -> Self {
        Cursor {
            path,
            bytes,
            pos: start.min(bytes.len()),
            encoding,
            known: std::cell::Cell::new((0, 1)),
        }
    }

    fn line(&self) -> usize {
        let mut pos = self.pos;
        if let Encoding::Ascii = self.encoding {
            // The line of the next token, not of the whitespace before it.
            while self.bytes.get(pos).is_some_and(u8::is_ascii_whitespace) {
                pos += 1;
            }
        }
        let pos = pos.min(self.bytes.len());
        let (at, line) = self.known.get();
        let line = if pos >= at {
            line + self.bytes[at..pos].iter().filter(|&&b| b == b'\n').count()
        } else {
            line_of_offset(self.bytes, pos)
        };
        self.known.set((pos, line));
        line
    }

    fn error(&self, what: &str) -> Error {
        Error::parse(
            self.path,
            self.line(),
            format!("invalid $Nodes section: expected {what}"),
        )
    }

    fn token(&mut self, what: &str) -> Result<&'a str> {
        let bytes = self.bytes;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(u8::is_ascii_whitespace)
        {
            self.pos += 1;
        }
        let begin = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        if begin == self.pos {
            return Err(self.error(what));
        }
        std::str::from_utf8(&bytes[begin..self.pos]).map_err(|_| self.error(what))
    }

    fn raw(&mut self, len: usize, what: &str) -> Result<u64> {
        let Encoding::Binary { little_endian, .. } = self.encoding else {
            return Err(self.error(what));
        };
        let chunk = self
            .bytes
            .get(self.pos..self.pos.saturating_add(len))
            .ok_or_else(|| self.error(what))?;
        let mut b = [0u8; 8];
        let value = if little_endian {
            b[..len].copy_from_slice(chunk);
            u64::from_le_bytes(b)
        } else {
            b[8 - len..].copy_from_slice(chunk);
            u64::from_be_bytes(b)
        };
        self.pos += len;
        Ok(value)
    }

    fn size_t(&mut self, what: &str) -> Result<u64> {
        match self.encoding {
            Encoding::Ascii => {
                let t = self.token(what)?;
                let parsed = t.parse().ok();
                parsed.ok_or_else(|| self.error(what))
            }
            Encoding::Binary { size, .. } => self.raw(size, what),
        }
    }

    fn int(&mut self, what: &str) -> Result<i64> {
        match self.encoding {
            Encoding::Ascii => {
                let t = self.token(what)?;
                let parsed = t.parse().ok();
                parsed.ok_or_else(|| self.error(what))
            }
            Encoding::Binary { .. } => Ok(i64::from(self.raw(4, what)? as u32 as i32)),
        }
    }

    fn double(&mut self, what: &str) -> Result<()> {
        match self.encoding {
            Encoding::Ascii => self.token(what).map(|_| ()),
            Encoding::Binary { .. } => self.raw(8, what).map(|_| ()),
        }
    }
}
