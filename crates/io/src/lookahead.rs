//! One token of lookahead over a scanner: the shared front of the hand-written curve-file readers
//! ([`crate::pbrt_curves`], [`crate::usda_curves`]), whose grammars each decide on the next token.

/// A byte offset into the text being read and what was wrong there.
pub(crate) type Located = (usize, String);

/// Reads the next token of a text, or `None` at its end.
pub(crate) trait Scan {
    type Token: Copy;
    fn scan(&mut self) -> Result<Option<Self::Token>, Located>;
}

/// A scanner with one token of lookahead.
pub(crate) struct Lookahead<S: Scan> {
    pub(crate) scanner: S,
    peeked: Option<Option<S::Token>>,
}

impl<S: Scan> Lookahead<S> {
    pub(crate) fn new(scanner: S) -> Self {
        Self { scanner, peeked: None }
    }

    /// The next token, left in place.
    pub(crate) fn peek(&mut self) -> Result<Option<S::Token>, Located> {
        if self.peeked.is_none() {
            self.peeked = Some(self.scanner.scan()?);
        }
        Ok(self.peeked.expect("just set"))
    }

    /// The next token, consumed.
    #[allow(clippy::should_implement_trait)] // fallible: not an `Iterator::next`
    pub(crate) fn next(&mut self) -> Result<Option<S::Token>, Located> {
        match self.peeked.take() {
            Some(t) => Ok(t),
            None => self.scanner.scan(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Digits of a text, one token each; a letter is an error at its offset.
    struct Digits<'a>(&'a [u8], usize);

    impl Scan for Digits<'_> {
        type Token = u8;
        fn scan(&mut self) -> Result<Option<u8>, Located> {
            let Some(&c) = self.0.get(self.1) else { return Ok(None) };
            if !c.is_ascii_digit() {
                return Err((self.1, "not a digit".into()));
            }
            self.1 += 1;
            Ok(Some(c - b'0'))
        }
    }

    #[test]
    fn peek_leaves_the_token_and_next_takes_it() {
        let mut lx = Lookahead::new(Digits(b"12x", 0));
        assert_eq!(lx.peek(), Ok(Some(1)));
        assert_eq!(lx.peek(), Ok(Some(1)));
        assert_eq!(lx.next(), Ok(Some(1)));
        assert_eq!(lx.next(), Ok(Some(2)));
        assert_eq!(lx.peek(), Err((2, "not a digit".into())));
        let mut end = Lookahead::new(Digits(b"", 0));
        assert_eq!(end.next(), Ok(None));
        assert_eq!(end.peek(), Ok(None));
    }
}
