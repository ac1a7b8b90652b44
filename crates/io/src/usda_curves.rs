//! USD `BasisCurves` prims of `.usda` text (the text form of Pixar's Universal Scene
//! Description), read into [`Strands`], and written from them.
//!
//! # What is read
//! * The layer must start with the header line `#usda 1.0`. Elsewhere `#` starts a comment.
//! * Prims `def|over|class [TypeName] "name" [( metadata )] { … }`, nested at most
//!   [`MAX_PRIM_DEPTH`] deep. The
//!   curves are the `def BasisCurves` prims whose ancestors are all `def`s (an `over` or a
//!   `class` does not define geometry in a standalone layer).
//! * On a `BasisCurves` prim: `point3f[] points`, `int[] curveVertexCounts`, `float[] widths`
//!   with its `interpolation` metadata (`constant`, `uniform`, `vertex` — the default —
//!   or `varying`), `uniform token type` (`linear`, or `cubic`, the default), `uniform token
//!   basis` (`bezier`, the default, `bspline` or `catmullRom`), `uniform token wrap`
//!   (`nonperiodic`, the default, or `pinned`; `periodic` is refused). Without `widths`
//!   every width is 1, USD's fallback.
//! * `normal3f[] normals` (or `primvars:normals`), with its `interpolation` (`constant`,
//!   `uniform`, `vertex` — the default — or `varying`): curves with normals are ribbons
//!   ([`CurveKind::Ribbon`], the width along `n × tangent`), without them round tubes. They are
//!   kept one per span end ([`Strands::normals`]): `varying` as given; `vertex` normals are
//!   blended with the basis' weights at each span end (the control points there for linear and
//!   Bézier curves), normalised; inside a span the normal is then interpolated spherically
//!   between its ends (exact for `varying`, an approximation of a cubic blend for `vertex`).
//!   Normals are carried by the inverse transpose of the transforms. Zero and non-finite
//!   normals are refused; all curves of a file have normals or none do.
//! * Transforms: `xformOp:translate`, `xformOp:scale`, `xformOp:rotateX|Y|Z`,
//!   `xformOp:rotateXYZ` (and the five other axis orders), `xformOp:transform` (a row-vector
//!   `matrix4d`, translation in the last row, as USD writes it), each with an optional
//!   `:suffix`, applied in the order of `xformOpOrder` (the last op first to the point), with
//!   `!invert!` and `!resetXformStack!`; the transforms of all ancestors are composed.
//!   Rotations are in degrees in the file. Widths are multiplied by the transform's scale,
//!   `|det M₃|^{1/3}` (exact for a uniform scale).
//! * `varying` widths (one per span end) become control-point widths: exact for linear and
//!   Bézier curves (Bézier curves reproduce linear functions) and for the span ends of
//!   Catmull–Rom curves; for B-splines the control points take the value of the nearest span
//!   end (an approximation). `pinned` B-spline and Catmull–Rom curves get the phantom end
//!   points `2c₀ − c₁` and `2c_{n−1} − c_{n−2}` (and widths extrapolated the same way,
//!   clamped at 0) so that the curve reaches its end points.
//! * Composition is not read, and refused rather than left out: `references`, `payload`,
//!   `subLayers`, `inherits` and `specializes` in metadata, and prims inside
//!   variant sets, are errors that say to flatten the stage first (`usdcat --flatten`).
//! * Everything else — other prims and properties, relationships, variant sets without prims,
//!   metadata, dictionaries, time samples of properties not read here — is skipped with its
//!   balanced brackets. Time-sampled `points` (animation) are refused. All the curves of a file must
//!   share one type and basis.
//!
//! Every malformed input is an error naming the file, the line and the column and what was
//! expected.
//!
//! # What is written
//! One `def BasisCurves "hair"` prim with `type`, `basis`, `wrap = "nonperiodic"`,
//! `curveVertexCounts`, `points` and `widths` (`constant` when all are equal, else
//! `vertex`), and `normals` (`varying`) for ribbons. Numbers are printed in Rust's shortest form that reads back to the same `f32`,
//! so a write then a read gives the same bits.

use crate::lookahead::{Located, Lookahead, Scan};
use crate::scene_text::skip_blanks_and_comments;
use crate::strands::{Basis, CurveKind, Strands, StrandsError, line_column, utf8_text};
use std::fmt::Write as _;
use std::path::Path;

/// Reads the `BasisCurves` of the `.usda` file at `path`.
pub fn read(path: &Path) -> Result<Strands, StrandsError> {
    let text = load(path)?;
    parse_str(&text, path)
}

/// Reads the `BasisCurves` of `.usda` text; `path` names it in errors.
pub fn parse_str(text: &str, path: &Path) -> Result<Strands, StrandsError> {
    parse(text, path, false)
}

/// The bytes of text and the strands' point counts (no points), skipping the point arrays.
pub(crate) fn count(path: &Path) -> Result<(u64, Strands), StrandsError> {
    let text = load(path)?;
    Ok((text.len() as u64, parse(&text, path, true)?))
}

fn load(path: &Path) -> Result<String, StrandsError> {
    utf8_text(path, crate::input_file::read_bytes(path)?)
}

/// Writes `strands` as a `.usda` layer (module docs), atomically.
pub fn write(path: &Path, strands: &Strands) -> Result<(), StrandsError> {
    let text = to_text(strands)?;
    crate::image_file::write_atomically(path, |file| {
        use std::io::Write;
        file.write_all(text.as_bytes())
    })
    .map_err(|error| StrandsError::Io { path: path.into(), error })
}

/// The `.usda` text of `strands` (module docs).
pub fn to_text(strands: &Strands) -> Result<String, StrandsError> {
    strands.validate()?;
    let mut s = String::with_capacity(48 * strands.points.len() + 256);
    s.push_str("#usda 1.0\n(\n    doc = \"fiberlab strands\"\n)\n\ndef BasisCurves \"hair\"\n{\n");
    let (ty, basis) = match strands.basis {
        Basis::Linear => ("linear", None),
        Basis::Bezier => ("cubic", Some("bezier")),
        Basis::BSpline => ("cubic", Some("bspline")),
        Basis::CatmullRom => ("cubic", Some("catmullRom")),
    };
    let _ = writeln!(s, "    uniform token type = \"{ty}\"");
    if let Some(b) = basis {
        let _ = writeln!(s, "    uniform token basis = \"{b}\"");
    }
    s.push_str("    uniform token wrap = \"nonperiodic\"\n    int[] curveVertexCounts = [");
    for (i, c) in strands.counts.iter().enumerate() {
        let _ = write!(s, "{}{c}", if i > 0 { ", " } else { "" });
    }
    s.push_str("]\n    point3f[] points = [");
    for (i, p) in strands.points.iter().enumerate() {
        let _ = write!(s, "{}({}, {}, {})", if i > 0 { ", " } else { "" }, p[0], p[1], p[2]);
    }
    s.push_str("]\n    float[] widths = [");
    let constant = strands.widths.first().filter(|&&w0| strands.widths.iter().all(|&w| w.to_bits() == w0.to_bits()));
    match constant {
        Some(w) => {
            let _ = write!(s, "{w}] (\n        interpolation = \"constant\"\n    )\n");
        }
        None => {
            for (i, w) in strands.widths.iter().enumerate() {
                let _ = write!(s, "{}{w}", if i > 0 { ", " } else { "" });
            }
            s.push_str("] (\n        interpolation = \"vertex\"\n    )\n");
        }
    }
    if !strands.normals.is_empty() {
        s.push_str("    normal3f[] normals = [");
        for (i, n) in strands.normals.iter().enumerate() {
            let _ = write!(s, "{}({}, {}, {})", if i > 0 { ", " } else { "" }, n[0], n[1], n[2]);
        }
        s.push_str("] (\n        interpolation = \"varying\"\n    )\n");
    }
    s.push_str("}\n");
    Ok(s)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Ident,
    Number,
    Str,
    /// `<path>` or `@asset@`.
    Reference,
    Punct,
}

#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    kind: Kind,
    /// The text (a string's without quotes).
    text: &'a str,
    offset: usize,
}

impl Token<'_> {
    fn is(&self, p: &str) -> bool {
        self.kind == Kind::Punct && self.text == p
    }
    fn describe(&self) -> String {
        match self.kind {
            Kind::Ident => format!("`{}`", self.text),
            Kind::Number => format!("the number {}", self.text),
            Kind::Str => format!("the string \"{}\"", self.text),
            Kind::Reference => format!("the reference {}", self.text),
            Kind::Punct => format!("`{}`", self.text),
        }
    }
}

/// The tokens of a `.usda` file's text.
struct Scanner<'a> {
    text: &'a str,
    pos: usize,
}

type Lexer<'a> = Lookahead<Scanner<'a>>;

impl<'a> Lexer<'a> {
    /// The next token, which must exist.
    fn expect(&mut self, what: &str) -> Result<Token<'a>, Located> {
        self.next()?.ok_or((self.scanner.text.len(), format!("expected {what}, found the end of the file")))
    }

    /// [`Self::punct`] with a context built only for the error.
    fn punct_with(&mut self, p: &str, context: impl FnOnce() -> String) -> Result<Token<'a>, Located> {
        match self.next()? {
            Some(t) if t.is(p) => Ok(t),
            Some(t) => Err((t.offset, format!("expected `{p}` {}, found {}", context(), t.describe()))),
            None => Err((self.scanner.text.len(), format!("expected `{p}` {}, found the end of the file", context()))),
        }
    }

    fn punct(&mut self, p: &str, context: &str) -> Result<Token<'a>, Located> {
        let t = self.expect(&format!("`{p}` {context}"))?;
        if t.is(p) { Ok(t) } else { Err((t.offset, format!("expected `{p}` {context}, found {}", t.describe()))) }
    }
}

impl<'a> Scan for Scanner<'a> {
    type Token = Token<'a>;

    fn scan(&mut self) -> Result<Option<Token<'a>>, Located> {
        let b = self.text.as_bytes();
        self.pos = skip_blanks_and_comments(b, self.pos);
        if self.pos >= b.len() {
            return Ok(None);
        }
        let start = self.pos;
        let c = b[start];
        let token = |kind, text| Ok(Some(Token { kind, text, offset: start }));
        match c {
            b'(' | b')' | b'[' | b']' | b'{' | b'}' | b'=' | b',' | b';' | b':' => {
                self.pos += 1;
                token(Kind::Punct, &self.text[start..start + 1])
            }
            b'"' | b'\'' => {
                let triple = b.len() >= start + 3 && b[start + 1] == c && b[start + 2] == c;
                let q = if triple { 3 } else { 1 };
                self.pos += q;
                loop {
                    match b.get(self.pos) {
                        None => return Err((start, "unterminated string: expected its closing quote".into())),
                        Some(b'\n') if !triple => {
                            return Err((
                                start,
                                "unterminated string: expected its closing quote on the same line".into(),
                            ));
                        }
                        Some(b'\\') => self.pos += 2,
                        Some(&x)
                            if x == c
                                && (!triple
                                    || (b.get(self.pos + 1) == Some(&c) && b.get(self.pos + 2) == Some(&c))) =>
                        {
                            break;
                        }
                        Some(_) => self.pos += 1,
                    }
                }
                self.pos += q;
                token(Kind::Str, &self.text[start + q..self.pos - q])
            }
            b'<' | b'@' => {
                let close = if c == b'<' { b'>' } else { b'@' };
                let end = b[start + 1..].iter().position(|&x| x == close || x == b'\n');
                match end {
                    Some(e) if b[start + 1 + e] == close => {
                        self.pos = start + e + 2;
                        token(Kind::Reference, &self.text[start..self.pos])
                    }
                    _ => Err((start, format!("unterminated reference: expected `{}`", close as char))),
                }
            }
            b'0'..=b'9' | b'-' | b'+' | b'.' => {
                while self.pos < b.len()
                    && (b[self.pos].is_ascii_alphanumeric() || matches!(b[self.pos], b'.' | b'-' | b'+'))
                {
                    self.pos += 1;
                }
                token(Kind::Number, &self.text[start..self.pos])
            }
            c if c.is_ascii_alphabetic() || c == b'_' || c == b'!' => {
                while self.pos < b.len()
                    && (b[self.pos].is_ascii_alphanumeric() || matches!(b[self.pos], b'_' | b':' | b'.' | b'!'))
                {
                    self.pos += 1;
                }
                token(Kind::Ident, &self.text[start..self.pos])
            }
            _ => {
                let ch = self.text[start..].chars().next().unwrap_or('?');
                Err((start, format!("unexpected character `{}`", ch.escape_default())))
            }
        }
    }
}

/// A 4×4 matrix acting on column vectors, `m[row][column]`.
type Mat4 = [[f64; 4]; 4];
const IDENTITY: Mat4 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn axis_rotation(axis: usize, degrees: f64) -> Mat4 {
    let (s, c) = degrees.to_radians().sin_cos();
    let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut m = IDENTITY;
    m[i][i] = c;
    m[i][j] = -s;
    m[j][i] = s;
    m[j][j] = c;
    m
}

/// Inverse of an affine matrix (last row 0 0 0 1); `None` when singular or projective.
fn affine_inverse(m: &Mat4) -> Option<Mat4> {
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        return None;
    }
    let a = |i: usize, j: usize| m[i][j];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // The adjugate over the determinant (cyclic indices give the cofactors' signs), then the
    // translation moved back through it.
    let mut inv = IDENTITY;
    for (i, row) in inv.iter_mut().enumerate().take(3) {
        for (j, v) in row.iter_mut().enumerate().take(3) {
            let (r0, r1, c0, c1) = ((j + 1) % 3, (j + 2) % 3, (i + 1) % 3, (i + 2) % 3);
            *v = (a(r0, c0) * a(r1, c1) - a(r0, c1) * a(r1, c0)) / det;
        }
        row[3] = -(0..3).map(|k| row[k] * m[k][3]).sum::<f64>();
    }
    Some(inv)
}

/// A normal carried through `m`: by the inverse transpose of its 3×3 part, normalised.
fn transform_normal(m: &Mat4, n: [f32; 3]) -> [f32; 3] {
    let inv = affine_inverse(m).unwrap_or(IDENTITY);
    let n = n.map(f64::from);
    // (M⁻ᵀ n)_r = Σ_c (M⁻¹)_{c r} n_c.
    let out: [f64; 3] = [0, 1, 2].map(|r| (0..3).map(|c| inv[c][r] * n[c]).sum::<f64>());
    let l = (out[0] * out[0] + out[1] * out[1] + out[2] * out[2]).sqrt();
    out.map(|v| (v / l) as f32)
}

fn det3(m: &Mat4) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// A `BasisCurves` prim as read, before its ancestors' transforms.
struct CurvePrim {
    offset: usize,
    points: Vec<[f32; 3]>,
    counts: Vec<u32>,
    widths: Vec<f32>,
    /// One per span end, or none (module docs).
    normals: Vec<[f32; 3]>,
    /// `normals` is authored (also in count mode, where they are not read).
    has_normals: bool,
    basis: Basis,
    /// Parent-from-prim so far (the prim's own ops and those of the ancestors applied).
    to_parent: Mat4,
    /// `!resetXformStack!` was met: the ancestors above do not apply.
    reset: bool,
}

/// `widths`: where its value starts, the values, and the `interpolation` metadata (where, what).
type Widths = (usize, Vec<f32>, Option<(usize, String)>);

/// `normals`: where its value starts, the values, and the `interpolation` metadata.
type Normals = (usize, Vec<[f32; 3]>, Option<(usize, String)>);

/// What a prim body holds that this reader uses.
#[derive(Default)]
struct Props {
    points: Option<(usize, Vec<[f32; 3]>)>,
    counts: Option<(usize, Vec<u32>)>,
    widths: Option<Widths>,
    normals: Option<Normals>,
    ty: Option<(usize, String)>,
    basis: Option<(usize, String)>,
    wrap: Option<(usize, String)>,
    op_order: Option<(usize, Vec<(usize, String)>)>,
    ops: Vec<(String, usize, Vec<f64>)>,
    /// Points given (counted in count mode).
    point_count: usize,
    /// The first time-sampled property among those read here.
    animated: Option<Located>,
}

struct Parser<'a> {
    lx: Lexer<'a>,
    count_only: bool,
}

/// How deep prims may nest (the reader recurses once per level; deeper files are refused
/// before the stack could overflow).
pub const MAX_PRIM_DEPTH: usize = 256;

/// How deep the tuples of a value may nest (a matrix is two levels).
pub const MAX_TUPLE_DEPTH: usize = 8;

/// Metadata entries that compose other layers or prims into this one: refused.
const COMPOSITION_ARCS: [&str; 5] = ["references", "payload", "subLayers", "inherits", "specializes"];

fn parse(text: &str, path: &Path, count_only: bool) -> Result<Strands, StrandsError> {
    let located = |(offset, message): Located| {
        let (line, column) = line_column(text, offset);
        StrandsError::Syntax { path: path.into(), line, column, message }
    };
    let first = text.lines().next().unwrap_or("");
    let mut words = first.split_whitespace();
    if words.next() != Some("#usda") || words.next() != Some("1.0") {
        return Err(located((
            0,
            format!("expected the header line `#usda 1.0`, found `{}`", first.chars().take(40).collect::<String>()),
        )));
    }
    let mut p = Parser { lx: Lexer::new(Scanner { text, pos: first.len() }), count_only };
    let prims = p.layer().map_err(located)?;
    let mut out = Strands {
        points: Vec::new(),
        widths: Vec::new(),
        counts: Vec::new(),
        basis: Basis::Linear,
        kind: CurveKind::Cylinder,
        normals: Vec::new(),
    };
    let mut first_ribbon: Option<bool> = None;
    let mut first_basis: Option<Basis> = None;
    for prim in prims {
        match first_basis {
            None => first_basis = Some(prim.basis),
            Some(b) if b != prim.basis => {
                return Err(located((
                    prim.offset,
                    format!(
                        "these curves are {} but the file's earlier curves are {b}; fiberlab reads one basis per file",
                        prim.basis
                    ),
                )));
            }
            Some(_) => {}
        }
        let ribbon = prim.has_normals;
        match first_ribbon {
            None => first_ribbon = Some(ribbon),
            Some(r) if r != ribbon => {
                return Err(located((
                    prim.offset,
                    format!(
                        "these curves have {} but the file's earlier curves {}; fiberlab reads one curve type per \
                         file (ribbons with normals, or tubes without)",
                        if ribbon { "normals" } else { "no normals" },
                        if r { "have normals" } else { "do not" }
                    ),
                )));
            }
            Some(_) => {}
        }
        let m = prim.to_parent;
        let scale = det3(&m).abs().cbrt();
        if !(scale > 0.0 && scale.is_finite()) {
            return Err(located((
                prim.offset,
                format!(
                    "the prim's transform is singular (a scale of 0 along some axis: |det| = {:e}); its curves would \
                     have no width",
                    det3(&m).abs()
                ),
            )));
        }
        for (i, q) in prim.points.iter().enumerate() {
            let p = q.map(f64::from);
            let h: Vec<f64> = (0..4).map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]).collect();
            let world = [h[0] / h[3], h[1] / h[3], h[2] / h[3]].map(|v| v as f32);
            if !world.iter().all(|v| v.is_finite()) {
                return Err(located((
                    prim.offset,
                    format!("point {i} is not finite after the transforms ({world:?})"),
                )));
            }
            out.points.push(if m == IDENTITY { *q } else { world });
        }
        out.widths.extend(prim.widths.iter().map(|&w| if m == IDENTITY { w } else { (f64::from(w) * scale) as f32 }));
        out.counts.extend(prim.counts);
        out.normals.extend(prim.normals.iter().map(|&n| if m == IDENTITY { n } else { transform_normal(&m, n) }));
    }
    out.basis = first_basis.unwrap_or(Basis::Linear);
    if first_ribbon == Some(true) {
        out.kind = CurveKind::Ribbon;
    }
    Ok(out)
}

impl<'a> Parser<'a> {
    fn layer(&mut self) -> Result<Vec<CurvePrim>, Located> {
        if self.lx.peek()?.is_some_and(|t| t.is("(")) {
            self.metadata()?;
        }
        let mut prims = Vec::new();
        while let Some(t) = self.lx.next()? {
            match t.text {
                "def" | "over" | "class" if t.kind == Kind::Ident => prims.extend(self.prim(t, t.text == "def", 1)?),
                _ => {
                    return Err((
                        t.offset,
                        format!("expected a prim (`def`, `over` or `class`), found {}", t.describe()),
                    ));
                }
            }
        }
        Ok(prims)
    }

    /// Skips one value or bracketed group starting at the next token: `( … )`, `[ … ]`,
    /// `{ … }` with their nesting checked, or a single token.
    fn skip_balanced(&mut self) -> Result<(), Located> {
        self.scan_balanced(|_, _| Ok(()))
    }

    /// [`Self::skip_balanced`], handing every token inside the brackets to `inside` with its
    /// bracket depth (1: directly inside the first bracket).
    fn scan_balanced(
        &mut self,
        mut inside: impl FnMut(usize, Token<'a>) -> Result<(), Located>,
    ) -> Result<(), Located> {
        let first = self.lx.expect("a value")?;
        let close = match first.text {
            "(" if first.kind == Kind::Punct => ")",
            "[" if first.kind == Kind::Punct => "]",
            "{" if first.kind == Kind::Punct => "}",
            ")" | "]" | "}" if first.kind == Kind::Punct => {
                return Err((first.offset, format!("{} without a matching opening bracket", first.describe())));
            }
            _ => return Ok(()),
        };
        let mut stack = vec![(close, first.offset)];
        while let Some(&(want, opened)) = stack.last() {
            let t = self.lx.next()?.ok_or((
                opened,
                format!("this bracket is never closed (expected `{want}` before the end of the file)"),
            ))?;
            if t.kind != Kind::Punct {
                inside(stack.len(), t)?;
                continue;
            }
            match t.text {
                "(" => stack.push((")", t.offset)),
                "[" => stack.push(("]", t.offset)),
                "{" => stack.push(("}", t.offset)),
                ")" | "]" | "}" if t.text == want => {
                    stack.pop();
                }
                ")" | "]" | "}" => {
                    return Err((
                        t.offset,
                        format!(
                            "expected `{want}` (to close the bracket opened at {}), found {}",
                            opened_at(self.lx.scanner.text, opened),
                            t.describe()
                        ),
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Skips a `( … )` metadata block, refusing the composition arcs among its entries
    /// ([`COMPOSITION_ARCS`]): what they would bring in is not read, and leaving it out without
    /// a word would render a different groom.
    fn metadata(&mut self) -> Result<(), Located> {
        self.scan_balanced(|depth, t| {
            if depth == 1 && t.kind == Kind::Ident && COMPOSITION_ARCS.contains(&t.text) {
                return Err((
                    t.offset,
                    format!(
                        "`{}`: fiberlab reads the curves of this one layer and does not compose others \
                         (references, payloads, sublayers, inherits, specializes); flatten the stage first, \
                         e.g. `usdcat --flatten in.usda -o flat.usda`",
                        t.text
                    ),
                ));
            }
            Ok(())
        })
    }

    /// A prim after its specifier; returns its curves (and its descendants') with the prim's
    /// transform applied. `depth` is its nesting depth (1 for a prim of the layer), at most
    /// [`MAX_PRIM_DEPTH`]: checked before the prim is read, so no input overflows the stack.
    fn prim(&mut self, spec: Token<'a>, defines: bool, depth: usize) -> Result<Vec<CurvePrim>, Located> {
        if depth > MAX_PRIM_DEPTH {
            return Err((spec.offset, format!("prims nest more than {MAX_PRIM_DEPTH} deep")));
        }
        let mut type_name = None;
        let mut name = self.lx.expect("a prim type or name")?;
        if name.kind == Kind::Ident {
            type_name = Some(name.text);
            name = self.lx.expect("a prim name")?;
        }
        if name.kind != Kind::Str {
            return Err((
                name.offset,
                format!("expected the prim's quoted name after `{}`, found {}", spec.text, name.describe()),
            ));
        }
        if self.lx.peek()?.is_some_and(|t| t.is("(")) {
            self.metadata()?;
        }
        let open = self.lx.punct("{", "to open the prim's body")?;
        let mut props = Props::default();
        let mut children = Vec::new();
        loop {
            let t =
                self.lx.next()?.ok_or((open.offset, "this prim's `{` is never closed (expected `}`)".to_string()))?;
            if t.is("}") {
                break;
            }
            if t.is(";") {
                continue;
            }
            if t.kind != Kind::Ident {
                return Err((t.offset, format!("expected a property, a child prim or `}}`, found {}", t.describe())));
            }
            match t.text {
                "def" | "over" | "class" => children.extend(self.prim(t, defines && t.text == "def", depth + 1)?),
                "variantSet" => {
                    let _name = self.lx.expect("the variant set's name")?;
                    self.lx.punct("=", "after the variant set's name")?;
                    // Prims inside a variant are not read: refused rather than left out.
                    self.scan_balanced(|_, t| match t.text {
                        "def" | "over" | "class" if t.kind == Kind::Ident => Err((
                            t.offset,
                            "a prim inside a variant set: fiberlab does not select variants; flatten the \
                             stage first, e.g. `usdcat --flatten in.usda -o flat.usda`"
                                .to_string(),
                        )),
                        _ => Ok(()),
                    })?;
                }
                "rel" => {
                    let _name = self.lx.expect("the relationship's name")?;
                    self.rest_of_property()?;
                }
                "reorder" => {
                    let _what = self.lx.expect("what to reorder")?;
                    self.rest_of_property()?;
                }
                _ => self.property(t, &mut props)?,
            }
        }
        let is_curve = defines && type_name == Some("BasisCurves");
        if let Some(animated) = props.animated.take()
            && (is_curve || !children.is_empty())
        {
            return Err(animated);
        }
        let (local, reset_here) = self.local_transform(&props)?;
        let mut curves = Vec::new();
        if is_curve {
            curves.push(self.curve_prim(spec, props)?);
        }
        curves.extend(children);
        for c in &mut curves {
            if !c.reset {
                c.to_parent = mul(&local, &c.to_parent);
                c.reset = reset_here;
            }
        }
        Ok(curves)
    }

    /// After a property's name: an optional `= value` and an optional `( metadata )`.
    fn rest_of_property(&mut self) -> Result<(), Located> {
        if self.lx.peek()?.is_some_and(|t| t.is("=")) {
            self.lx.next()?;
            self.skip_balanced()?;
        }
        if self.lx.peek()?.is_some_and(|t| t.is("(")) {
            self.skip_balanced()?;
        }
        Ok(())
    }

    fn property(&mut self, first: Token<'a>, props: &mut Props) -> Result<(), Located> {
        let mut t = first;
        while matches!(t.text, "custom" | "uniform" | "varying" | "config" | "prepend" | "append" | "add" | "delete") {
            t = self.lx.expect("a property type")?;
        }
        if t.kind != Kind::Ident {
            return Err((t.offset, format!("expected a property type, found {}", t.describe())));
        }
        let ty = t.text;
        let mut array = false;
        if self.lx.peek()?.is_some_and(|x| x.is("[")) {
            self.lx.next()?;
            self.lx.punct("]", "after `[` in an array type")?;
            array = true;
        }
        let name = self.lx.expect("a property name")?;
        if name.kind != Kind::Ident {
            return Err((name.offset, format!("expected the name of the `{ty}` property, found {}", name.describe())));
        }
        let (base, suffix) = match name.text.rsplit_once('.') {
            Some((b, s @ ("timeSamples" | "connect" | "spline"))) => (b, Some(s)),
            _ => (name.text, None),
        };
        let base = if base == "primvars:normals" { "normals" } else { base };
        let read_here = matches!(
            base,
            "points" | "curveVertexCounts" | "widths" | "normals" | "type" | "basis" | "wrap" | "xformOpOrder"
        ) || base.starts_with("xformOp:");
        if let Some(s) = suffix {
            if s == "timeSamples" && read_here && props.animated.is_none() {
                // An error only if the prim turns out to hold or to move curves.
                props.animated = Some((
                    name.offset,
                    format!(
                        "`{}`: time samples (animation) of the properties read here are not supported; give a default value",
                        name.text
                    ),
                ));
            }
            return self.rest_of_property();
        }
        if !read_here || !self.lx.peek()?.is_some_and(|x| x.is("=")) {
            return self.rest_of_property();
        }
        self.lx.next()?;
        let at = self.lx.peek()?.map_or(self.lx.scanner.text.len(), |x| x.offset);
        let check_type = |want: &str, want_array: bool| -> Result<(), Located> {
            let ok = if want == "point3f" {
                matches!(ty, "point3f" | "float3" | "vector3f" | "normal3f" | "color3f")
            } else {
                ty == want
            };
            if !ok || array != want_array {
                return Err((
                    t.offset,
                    format!(
                        "`{}` must be `{want}{}`, found `{ty}{}`",
                        name.text,
                        if want_array { "[]" } else { "" },
                        if array { "[]" } else { "" }
                    ),
                ));
            }
            Ok(())
        };
        match base {
            "points" => {
                check_type("point3f", true)?;
                let mut count = 0;
                let points = self.points(&mut count, "point")?;
                props.point_count = if self.count_only { count } else { points.len() };
                props.points = Some((at, points));
            }
            "curveVertexCounts" => {
                check_type("int", true)?;
                let v = self.number_list(
                    |t| t.text.parse::<u32>().ok().filter(|_| !t.text.starts_with('+')),
                    "a non-negative integer",
                )?;
                props.counts = Some((at, v));
            }
            "widths" => {
                check_type("float", true)?;
                let v = self.number_list(
                    |t| t.text.parse::<f32>().ok().filter(|w| w.is_finite() && *w >= 0.0),
                    "a finite width ≥ 0",
                )?;
                let interpolation = self.interpolation()?;
                props.widths = Some((at, v, interpolation));
                return Ok(());
            }
            "normals" => {
                if ty != "normal3f" || !array {
                    return Err((
                        t.offset,
                        format!("`{}` must be `normal3f[]`, found `{ty}{}`", name.text, if array { "[]" } else { "" }),
                    ));
                }
                let mut count = 0;
                let normals = self.points(&mut count, "normal")?;
                if let Some(i) = normals.iter().position(|n| *n == [0.0; 3]) {
                    return Err((
                        at,
                        format!("normal {i} is (0, 0, 0); a normal orients the ribbon and must be non-zero"),
                    ));
                }
                let interpolation = self.interpolation()?;
                props.normals = Some((at, normals, interpolation));
                return Ok(());
            }
            "type" | "basis" | "wrap" => {
                check_type("token", false)?;
                let v = self.lx.expect("a quoted token")?;
                if v.kind != Kind::Str {
                    return Err((
                        v.offset,
                        format!("`{}`: expected a quoted token, found {}", name.text, v.describe()),
                    ));
                }
                let slot = match base {
                    "type" => &mut props.ty,
                    "basis" => &mut props.basis,
                    _ => &mut props.wrap,
                };
                *slot = Some((v.offset, v.text.to_string()));
            }
            "xformOpOrder" => {
                check_type("token", true)?;
                props.op_order = Some((at, self.string_list()?));
            }
            _ => {
                let mut v = Vec::new();
                self.numbers_nested(&mut v, 0)?;
                props.ops.push((base.to_string(), at, v));
            }
        }
        if self.lx.peek()?.is_some_and(|x| x.is("(")) {
            self.skip_balanced()?;
        }
        Ok(())
    }

    /// `( … interpolation = "…" … )` after `widths`, if present.
    fn interpolation(&mut self) -> Result<Option<(usize, String)>, Located> {
        if !self.lx.peek()?.is_some_and(|x| x.is("(")) {
            return Ok(None);
        }
        let open = self.lx.next()?.expect("peeked");
        let mut found = None;
        loop {
            let t = self.lx.expect("metadata or `)`")?;
            if t.is(")") {
                return Ok(found);
            }
            if t.is(";") {
                continue;
            }
            if t.kind == Kind::Str {
                continue; // a doc string
            }
            if t.kind != Kind::Ident {
                return Err((
                    t.offset,
                    format!(
                        "in the metadata opened at {}: expected `key = value` or `)`, found {}",
                        opened_at(self.lx.scanner.text, open.offset),
                        t.describe()
                    ),
                ));
            }
            self.lx.punct("=", &format!("after the metadata key `{}`", t.text))?;
            if t.text == "interpolation" {
                let v = self.lx.expect("a quoted interpolation")?;
                if v.kind != Kind::Str {
                    return Err((
                        v.offset,
                        format!("`interpolation`: expected a quoted token, found {}", v.describe()),
                    ));
                }
                found = Some((v.offset, v.text.to_string()));
            } else {
                self.skip_balanced()?;
            }
        }
    }

    /// `[ (x, y, z), … ]` as `f32`; in count mode the tuples are only counted (`count`).
    /// `what` names an element in errors (`point`, `normal`).
    fn points(&mut self, count: &mut usize, what: &str) -> Result<Vec<[f32; 3]>, Located> {
        if self.count_only {
            let start = self.lx.scanner.pos;
            self.skip_balanced()?;
            // The tuples of the list: its `(`s (the numbers are not parsed).
            *count = self.lx.scanner.text[start..self.lx.scanner.pos].bytes().filter(|&b| b == b'(').count();
            return Ok(Vec::new());
        }
        let open = self.lx.punct("[", "to open the points")?;
        let mut out = Vec::new();
        loop {
            let t =
                self.lx.next()?.ok_or((open.offset, "the points' `[` is never closed (expected `]`)".to_string()))?;
            if t.is("]") {
                return Ok(out);
            }
            if !out.is_empty() {
                if !t.is(",") {
                    return Err((
                        t.offset,
                        format!("expected `,` or `]` after {what} {}, found {}", out.len() - 1, t.describe()),
                    ));
                }
                if self.lx.peek()?.is_some_and(|x| x.is("]")) {
                    continue;
                }
                let t2 = self.lx.expect("a tuple `(x, y, z)`")?;
                out.push(self.point(t2, out.len(), what)?);
            } else {
                out.push(self.point(t, 0, what)?);
            }
        }
    }

    fn point(&mut self, open: Token<'a>, index: usize, what: &str) -> Result<[f32; 3], Located> {
        if !open.is("(") {
            return Err((open.offset, format!("{what} {index}: expected `(x, y, z)`, found {}", open.describe())));
        }
        let mut p = [0.0f32; 3];
        for (k, v) in p.iter_mut().enumerate() {
            if k > 0 {
                self.lx.punct_with(",", || format!("between the coordinates of {what} {index}"))?;
            }
            let t = self.lx.expect("a coordinate")?;
            *v = match (t.kind, t.text.parse::<f32>()) {
                (Kind::Number, Ok(x)) if x.is_finite() => x,
                (Kind::Number | Kind::Ident, Ok(x)) => {
                    return Err((t.offset, format!("{what} {index}: coordinate {} is not finite ({x})", t.text)));
                }
                _ => return Err((t.offset, format!("{what} {index}: expected a number, found {}", t.describe()))),
            };
        }
        self.lx.punct_with(")", || format!("to close {what} {index} (3 coordinates)"))?;
        Ok(p)
    }

    /// `[ a, b, … ]` of single numbers.
    fn number_list<T>(&mut self, parse: impl Fn(&Token<'a>) -> Option<T>, what: &str) -> Result<Vec<T>, Located> {
        let open = self.lx.punct("[", "to open the list")?;
        let mut out = Vec::new();
        let mut want_value = true;
        loop {
            let t = self.lx.next()?.ok_or((open.offset, "this `[` is never closed (expected `]`)".to_string()))?;
            if t.is("]") {
                return Ok(out);
            }
            if want_value {
                let v = if matches!(t.kind, Kind::Number | Kind::Ident) { parse(&t) } else { None };
                out.push(
                    v.ok_or((t.offset, format!("element {}: expected {what}, found {}", out.len(), t.describe())))?,
                );
                want_value = false;
            } else if t.is(",") {
                want_value = true;
            } else {
                return Err((
                    t.offset,
                    format!("expected `,` or `]` after element {}, found {}", out.len() - 1, t.describe()),
                ));
            }
        }
    }

    /// `[ "a", "b", … ]`.
    fn string_list(&mut self) -> Result<Vec<(usize, String)>, Located> {
        let open = self.lx.punct("[", "to open the list")?;
        let mut out = Vec::new();
        loop {
            let t = self.lx.next()?.ok_or((open.offset, "this `[` is never closed (expected `]`)".to_string()))?;
            match t.kind {
                _ if t.is("]") => return Ok(out),
                _ if t.is(",") => {}
                Kind::Str => out.push((t.offset, t.text.to_string())),
                _ => return Err((t.offset, format!("expected a quoted token, `,` or `]`, found {}", t.describe()))),
            }
        }
    }

    /// The numbers of a value, flattened through nested tuples: `1`, `(1, 2, 3)`, `((…), …)`.
    fn numbers_nested(&mut self, out: &mut Vec<f64>, depth: usize) -> Result<(), Located> {
        let t = self.lx.expect("a number or a tuple")?;
        if depth > MAX_TUPLE_DEPTH {
            return Err((t.offset, format!("tuples nest more than {MAX_TUPLE_DEPTH} deep")));
        }
        if t.kind == Kind::Number {
            return match t.text.parse::<f64>() {
                Ok(v) if v.is_finite() => {
                    out.push(v);
                    Ok(())
                }
                _ => Err((t.offset, format!("expected a finite number, found {}", t.describe()))),
            };
        }
        if !t.is("(") {
            return Err((t.offset, format!("expected a number or `(`, found {}", t.describe())));
        }
        loop {
            self.numbers_nested(out, depth + 1)?;
            let sep = self.lx.expect("`,` or `)`")?;
            if sep.is(")") {
                return Ok(());
            }
            if !sep.is(",") {
                return Err((
                    sep.offset,
                    format!(
                        "expected `,` or `)` in the tuple opened at {}, found {}",
                        opened_at(self.lx.scanner.text, t.offset),
                        sep.describe()
                    ),
                ));
            }
        }
    }

    /// The prim's own transform (parent-from-prim) and whether it resets the stack.
    fn local_transform(&self, props: &Props) -> Result<(Mat4, bool), Located> {
        let Some((_, order)) = &props.op_order else {
            return Ok((IDENTITY, false));
        };
        let mut m = IDENTITY;
        let mut reset = false;
        for (i, (offset, op)) in order.iter().enumerate() {
            if op == "!resetXformStack!" {
                if i != 0 {
                    return Err((*offset, "`!resetXformStack!` must come first in xformOpOrder".into()));
                }
                reset = true;
                continue;
            }
            let (invert, name) = match op.strip_prefix("!invert!") {
                Some(n) => (true, n),
                None => (false, op.as_str()),
            };
            let (_, _, values) = props.ops.iter().rev().find(|(n, _, _)| n == name).ok_or((
                *offset,
                format!("xformOpOrder names `{name}`, but the prim has no such attribute with a value"),
            ))?;
            let kind = name.strip_prefix("xformOp:").unwrap_or(name);
            let kind = kind.split(':').next().unwrap_or(kind);
            let need = |n: usize| -> Result<(), Located> {
                if values.len() == n {
                    Ok(())
                } else {
                    Err((*offset, format!("`{name}` needs {n} numbers, found {}", values.len())))
                }
            };
            let sign = if invert { -1.0 } else { 1.0 };
            let op_m = match kind {
                "translate" => {
                    need(3)?;
                    let mut t = IDENTITY;
                    (0..3).for_each(|k| t[k][3] = sign * values[k]);
                    t
                }
                "scale" => {
                    need(3)?;
                    let mut s = IDENTITY;
                    for k in 0..3 {
                        s[k][k] = if invert { 1.0 / values[k] } else { values[k] };
                    }
                    s
                }
                "rotateX" | "rotateY" | "rotateZ" => {
                    need(1)?;
                    axis_rotation(usize::from(kind.as_bytes()[6] - b'X'), sign * values[0])
                }
                "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY" | "rotateZYX" => {
                    need(3)?;
                    // `rotateABC` applies A first: C·B·A on column vectors; inverted, the
                    // reverse order with negated angles.
                    let axes: Vec<usize> = kind.as_bytes()[6..9].iter().map(|&a| usize::from(a - b'X')).collect();
                    let r: Vec<Mat4> = (0..3).map(|k| axis_rotation(axes[k], sign * values[k])).collect();
                    if invert { mul(&mul(&r[0], &r[1]), &r[2]) } else { mul(&mul(&r[2], &r[1]), &r[0]) }
                }
                "transform" => {
                    need(16)?;
                    // USD's row-vector matrix, transposed to act on columns.
                    let mut t = [[0.0; 4]; 4];
                    for (k, &v) in values.iter().enumerate() {
                        t[k % 4][k / 4] = v;
                    }
                    if invert {
                        affine_inverse(&t)
                            .ok_or((*offset, format!("`{name}` cannot be inverted (singular or projective)")))?
                    } else {
                        t
                    }
                }
                other => {
                    return Err((
                        *offset,
                        format!(
                            "xformOp `{other}` is not supported (translate, scale, rotateX/Y/Z, rotateXYZ…, transform)"
                        ),
                    ));
                }
            };
            if !op_m.iter().flatten().all(|v| v.is_finite()) {
                return Err((*offset, format!("`{name}` gives a non-finite transform")));
            }
            m = mul(&m, &op_m);
        }
        Ok((m, reset))
    }

    fn curve_prim(&self, spec: Token<'a>, props: Props) -> Result<CurvePrim, Located> {
        let token = |slot: &Option<(usize, String)>, default: &str| {
            slot.as_ref().map_or((spec.offset, default.to_string()), |(o, s)| (*o, s.clone()))
        };
        let (ty_at, ty) = token(&props.ty, "cubic");
        let (basis_at, basis) = token(&props.basis, "bezier");
        let (wrap_at, wrap) = token(&props.wrap, "nonperiodic");
        let basis = match (ty.as_str(), basis.as_str()) {
            ("linear", _) => Basis::Linear,
            ("cubic", "bezier") => Basis::Bezier,
            ("cubic", "bspline") => Basis::BSpline,
            ("cubic", "catmullRom") => Basis::CatmullRom,
            ("cubic", other) => {
                return Err((
                    basis_at,
                    format!("basis must be \"bezier\", \"bspline\" or \"catmullRom\", found \"{other}\""),
                ));
            }
            (other, _) => return Err((ty_at, format!("type must be \"linear\" or \"cubic\", found \"{other}\""))),
        };
        let pinned = match wrap.as_str() {
            "nonperiodic" => false,
            "pinned" => true,
            "periodic" => {
                return Err((
                    wrap_at,
                    "wrap \"periodic\" (closed curves) is not supported; use \"nonperiodic\" or \"pinned\"".into(),
                ));
            }
            other => {
                return Err((
                    wrap_at,
                    format!("wrap must be \"nonperiodic\", \"pinned\" or \"periodic\", found \"{other}\""),
                ));
            }
        };
        let (counts_at, counts) =
            props.counts.ok_or((spec.offset, "a BasisCurves prim needs `int[] curveVertexCounts`".to_string()))?;
        let total: u64 = counts.iter().map(|&c| u64::from(c)).sum();
        // Phantom end points of pinned B-splines and Catmull–Rom curves.
        let phantom = pinned && matches!(basis, Basis::BSpline | Basis::CatmullRom);
        for (i, &c) in counts.iter().enumerate() {
            let n = c as usize + if phantom { 2 } else { 0 };
            if basis.spans(n).is_none() || (phantom && c < 2) {
                return Err((counts_at, format!("curve {i} has {c} vertices: {}", basis.rule())));
            }
        }
        let out_counts: Vec<u32> = counts.iter().map(|&c| c + if phantom { 2 } else { 0 }).collect();
        let (points_at, points) =
            props.points.ok_or((spec.offset, "a BasisCurves prim needs `point3f[] points`".to_string()))?;
        if props.point_count as u64 != total {
            return Err((points_at, format!("{} points, but curveVertexCounts add up to {total}", props.point_count)));
        }
        if self.count_only {
            return Ok(CurvePrim {
                offset: spec.offset,
                points: Vec::new(),
                counts: out_counts,
                widths: Vec::new(),
                normals: Vec::new(),
                has_normals: props.normals.is_some(),
                basis,
                to_parent: IDENTITY,
                reset: false,
            });
        }
        // Widths per control point (of the curve as given, before phantom points).
        let ranges: Vec<std::ops::Range<usize>> = {
            let mut s = 0;
            counts
                .iter()
                .map(|&c| {
                    let r = s..s + c as usize;
                    s = r.end;
                    r
                })
                .collect()
        };
        // Values per curve-varying primvar: one per span end plus one ("varying").
        let spans_plus_one = |c: u32| basis.spans(c as usize + if phantom { 2 } else { 0 }).unwrap_or(0) + 1;
        // A primvar's value count against what its interpolation needs.
        let check_count = |what: &str, len: usize, at, interp_at, interp: &str| {
            let expected = match interp {
                "constant" => 1,
                "uniform" => counts.len(),
                "vertex" => points.len(),
                "varying" => counts.iter().map(|&c| spans_plus_one(c)).sum(),
                other => {
                    return Err((
                        interp_at,
                        format!("{what} interpolation must be constant, uniform, vertex or varying, found \"{other}\""),
                    ));
                }
            };
            if len == expected {
                Ok(())
            } else {
                Err((at, format!("{len} {what}, but `{interp}` interpolation needs {expected}")))
            }
        };
        let widths: Vec<f32> = match props.widths {
            None => vec![1.0; points.len()],
            Some((at, w, interpolation)) => {
                let (interp_at, interp) =
                    interpolation.unwrap_or((at, if w.len() == 1 { "constant".into() } else { "vertex".into() }));
                check_count("widths", w.len(), at, interp_at, &interp)?;
                match interp.as_str() {
                    "constant" => vec![w[0]; points.len()],
                    "uniform" => {
                        ranges.iter().enumerate().flat_map(|(i, r)| std::iter::repeat_n(w[i], r.len())).collect()
                    }
                    "vertex" => w,
                    _ => {
                        let mut out = Vec::with_capacity(points.len());
                        let mut start = 0;
                        for &c in &counts {
                            let k = spans_plus_one(c);
                            let v = &w[start..start + k];
                            start += k;
                            for j in 0..c as usize {
                                out.push(match basis {
                                    Basis::Linear => v[j],
                                    Basis::Bezier => {
                                        let (i, m) = (j / 3, j % 3);
                                        if m == 0 { v[i] } else { v[i] + (v[i + 1] - v[i]) * m as f32 / 3.0 }
                                    }
                                    // The span ends are control points 1 … n−2 (phantom points
                                    // shift them by one).
                                    _ => v[(j + usize::from(phantom)).saturating_sub(1).min(k - 1)],
                                });
                            }
                        }
                        out
                    }
                }
            }
        };
        let has_normals = props.normals.is_some();
        let normals = match props.normals {
            None => Vec::new(),
            Some((at, n, interpolation)) => {
                let (interp_at, interp) = interpolation.unwrap_or((at, "vertex".into()));
                check_count("normals", n.len(), at, interp_at, &interp)?;
                let mut out = Vec::new();
                let mut start = 0;
                for (i, (&c, r)) in counts.iter().zip(&ranges).enumerate() {
                    let ends = spans_plus_one(c);
                    match interp.as_str() {
                        "constant" => out.extend(std::iter::repeat_n(n[0], ends)),
                        "uniform" => out.extend(std::iter::repeat_n(n[i], ends)),
                        "varying" => {
                            out.extend_from_slice(&n[start..start + ends]);
                            start += ends;
                        }
                        _ => {
                            // Per control point (phantom points take the end normals), blended
                            // with the basis' weights at each span end.
                            let mut v: Vec<[f32; 3]> = n[r.clone()].to_vec();
                            if phantom {
                                v.insert(0, v[0]);
                                v.push(v[v.len() - 1]);
                            }
                            for e in 0..ends {
                                let (span, t) = if e + 1 < ends { (e, 0.0) } else { (e - 1, 1.0) };
                                let s0 = basis.span_start(span);
                                let w = basis.weights(t);
                                let mut b = [0.0f64; 3];
                                for (m, &wm) in w.iter().enumerate().filter(|(_, w)| **w != 0.0) {
                                    for (k, bk) in b.iter_mut().enumerate() {
                                        *bk += wm * f64::from(v[s0 + m][k]);
                                    }
                                }
                                let l = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
                                if l.is_nan() || l <= 1e-12 {
                                    return Err((
                                        at,
                                        format!(
                                            "curve {i}: the vertex normals blend to zero at span end {e}; give varying normals"
                                        ),
                                    ));
                                }
                                out.push(b.map(|x| (x / l) as f32));
                            }
                        }
                    }
                }
                out
            }
        };
        let (points, widths) = if phantom {
            let mut p2 = Vec::with_capacity(points.len() + 2 * counts.len());
            let mut w2 = Vec::with_capacity(p2.capacity());
            let ext = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|k| (2.0 * f64::from(a[k]) - f64::from(b[k])) as f32);
            for r in &ranges {
                let (p, w) = (&points[r.clone()], &widths[r.clone()]);
                let n = p.len();
                p2.push(ext(p[0], p[1]));
                w2.push((2.0 * w[0] - w[1]).max(0.0));
                p2.extend_from_slice(p);
                w2.extend_from_slice(w);
                p2.push(ext(p[n - 1], p[n - 2]));
                w2.push((2.0 * w[n - 1] - w[n - 2]).max(0.0));
            }
            (p2, w2)
        } else {
            (points, widths)
        };
        Ok(CurvePrim {
            offset: spec.offset,
            points,
            counts: out_counts,
            widths,
            normals,
            has_normals,
            basis,
            to_parent: IDENTITY,
            reset: false,
        })
    }
}

fn opened_at(text: &str, offset: usize) -> String {
    let (line, column) = line_column(text, offset);
    format!("{line}:{column}")
}
