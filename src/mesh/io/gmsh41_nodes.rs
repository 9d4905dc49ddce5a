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
//! mshio gives no positions for elements either: [`element_lines`] finds the line of every
//! element of the `$Elements` section (header `<blocks> <elements> <min tag> <max tag>`, per block
//! `<entity dim> <entity tag> <element type> <elements in block>`, then per element its tag and
//! node tags, all size_t in binary files but the three block ints), for errors that name it.

use std::path::Path;

use super::text::line_of_offset;
use crate::base::error::{Error, Result};

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

/// The tag and 1-based line of every element of the `$Elements` section that starts at byte
/// `start` (just after the `$Elements` line), per block in file order, if the section reads as
/// mshio read it: `layout` gives per block its element count and the nodes per element. `None`
/// when it does not (the caller then names the section's line). For binary data the line is
/// the line count up to the element's byte offset. One pass over the section: the lines of all
/// elements cost what reading the section once costs (finding each element's line by reading
/// the section up to it made reading a file of n 6-node triangles O(n × file size)).
pub(crate) fn element_lines(
    path: &Path,
    bytes: &[u8],
    start: usize,
    encoding: Encoding,
    layout: &[(usize, usize)],
) -> Option<Vec<Vec<TagAt>>> {
    #[cfg(test)]
    SECTION_SCANS.with(|n| n.set(n.get() + 1));
    let mut cursor = Cursor::new(path, bytes, start, encoding);
    let size_t = |c: &mut Cursor| c.size_t("").ok();
    for _ in 0..4 {
        size_t(&mut cursor)?;
    }
    let mut out = Vec::with_capacity(layout.len());
    for &(count, nodes) in layout {
        for _ in 0..3 {
            cursor.int("").ok()?;
        }
        if size_t(&mut cursor)? != count as u64 {
            return None;
        }
        // No reservation from the count: each element consumes input (see `node_tags`).
        let mut block = Vec::new();
        for _ in 0..count {
            let line = cursor.line();
            block.push((size_t(&mut cursor)?, line));
            for _ in 0..nodes {
                size_t(&mut cursor)?;
            }
        }
        out.push(block);
    }
    Some(out)
}

#[cfg(test)]
thread_local! {
    /// How many times [`element_lines`] read an `$Elements` section on this thread: the
    /// structural check that a read is linear in the file's size.
    pub(crate) static SECTION_SCANS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
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

/// The first fault of an ASCII MSH 4.1 `$Elements` section read line by line, as Gmsh writes
/// it (a header line, per block a line `<entity dim> <entity tag> <element type> <count>` and
/// one line `<tag> <node tags…>` per element, then `$EndElements`): an element line with
/// another number of node tags than its type has, a block cut short by a `$` line, or a
/// missing `$EndElements`. mshio reads the section as a stream of numbers, so such a fault
/// surfaces where the shifted stream finally fails to parse, lines later (or as the next
/// tag it expected, "Tag", at the file's end); this names the line itself. `None` if the
/// section reads well this way, or holds element types whose node count is not known here
/// (the caller keeps mshio's message). For errors only: called when mshio failed.
pub(crate) fn ascii_elements_fault(path: &Path, bytes: &[u8], start: usize) -> Option<Error> {
    let text = String::from_utf8_lossy(&bytes[start.min(bytes.len())..]);
    let first_line = line_of_offset(bytes, start);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (first_line + i, l.trim()))
        .filter(|(_, l)| !l.is_empty());
    let fault = |line: usize, message: String| Some(Error::parse(path, line, message));
    let truncated = |line: usize| {
        fault(
            line,
            "the file ends inside the $Elements section: no $EndElements (the file is truncated?)"
                .to_string(),
        )
    };
    let last_line = first_line + text.lines().count().saturating_sub(1);
    let Some((_, header)) = lines.next() else {
        return truncated(last_line);
    };
    let numbers =
        |l: &str| -> Option<Vec<u64>> { l.split_whitespace().map(|f| f.parse().ok()).collect() };
    let blocks = match numbers(header).as_deref() {
        Some(&[blocks, _, _, _]) => blocks,
        _ => return None,
    };
    for b in 0..blocks {
        let Some((line, block)) = lines.next() else {
            return truncated(last_line);
        };
        let Some(&[_, _, code, count]) = numbers(block).as_deref() else {
            return fault(
                line,
                format!(
                    "expected the header of element block {} of {blocks} ('<entity dim> <entity tag> <element type> <count>'), found '{block}'",
                    b + 1
                ),
            );
        };
        let (name, nodes) = super::gmsh22::element_type(u32::try_from(code).ok()?)?;
        for k in 0..count {
            let Some((line, element)) = lines.next() else {
                return truncated(last_line);
            };
            let fields = element.split_whitespace().count();
            if element.starts_with('$') {
                return fault(
                    line,
                    format!(
                        "element block {} announces {count} elements, but '{element}' follows after {k}",
                        b + 1
                    ),
                );
            }
            if fields != 1 + nodes {
                return fault(
                    line,
                    format!(
                        "element line with {} node tags: a {name} element (type {code}) has {nodes} ('<tag> <{nodes} node tags>'; element {} of block {})",
                        fields.saturating_sub(1),
                        k + 1,
                        b + 1
                    ),
                );
            }
        }
    }
    match lines.next() {
        None => truncated(last_line),
        Some((_, "$EndElements")) => None,
        Some((line, other)) => fault(
            line,
            format!(
                "expected $EndElements after the {blocks} element blocks the header announces, found '{other}'"
            ),
        ),
    }
}
