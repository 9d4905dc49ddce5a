//! The `--cells NX,NY,NZ` argument of the validation programs.

/// Parses `NX,NY,NZ` (three non-negative integers, spaces allowed around each) into the cells
/// of a box grid; the message names the field that is not an integer, or the text when there
/// are not three.
pub fn parse_cells(text: &str) -> Result<[usize; 3], String> {
    let values: Vec<usize> = text
        .split(',')
        .map(|s| s.trim().parse::<usize>().map_err(|e| format!("'{s}': {e}")))
        .collect::<Result<_, _>>()?;
    values
        .try_into()
        .map_err(|_| format!("expected NX,NY,NZ, got '{text}'"))
}

#[cfg(test)]
mod tests {
    use super::parse_cells;

    #[test]
    fn three_integers_parse_and_anything_else_is_named() {
        assert_eq!(parse_cells("100, 20,20"), Ok([100, 20, 20]));
        assert!(parse_cells("100,20").unwrap_err().contains("got '100,20'"));
        assert!(parse_cells("100,x,20").unwrap_err().contains("'x'"));
    }
}
