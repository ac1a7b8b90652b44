//! What the text scene formats (pbrt-v4 and USD's `.usda`) share when they are tokenized: both
//! separate tokens by ASCII white space and both have `#` comments that run to the end of the
//! line.

/// The offset of the first byte at or after `pos` that is neither white space nor inside a `#`
/// comment (`text.len()` at the end).
pub(crate) fn skip_blanks_and_comments(text: &[u8], mut pos: usize) -> usize {
    loop {
        while pos < text.len() && text[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if pos < text.len() && text[pos] == b'#' {
            while pos < text.len() && text[pos] != b'\n' {
                pos += 1;
            }
            continue;
        }
        return pos;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blanks_and_comments_are_skipped_up_to_the_next_token() {
        let t = b"  # one\n\t# two # still two\r\n  Shape";
        assert_eq!(&t[skip_blanks_and_comments(t, 0)..], b"Shape");
        assert_eq!(skip_blanks_and_comments(b"x", 0), 0);
        assert_eq!(skip_blanks_and_comments(b"  # to the end", 0), 14);
        assert_eq!(skip_blanks_and_comments(b"", 0), 0);
    }
}
