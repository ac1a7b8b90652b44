//! The curve shapes of pbrt-v4 scene files (`.pbrt`, or gzip-compressed `.pbrt.gz`), read into
//! [`Strands`]. Everything else in the scene (camera, lights, materials, other shapes) is
//! skipped, with its arguments.
//!
//! # What is read
//! * The token grammar of pbrt's scene format (Pharr, Jakob and Humphreys, *Physically Based
//!   Rendering*, 4th ed., 2023, appendix C): `#` comments to the end of the line, `"quoted
//!   strings"` (with `\"`, `\\`, `\n`, `\t` escapes), `[` `]` brackets and bare words and
//!   numbers. A directive is a bare word; its arguments are numbers, strings and parameter
//!   lists `"type name" value` whose value is one number, string or bare `true`/`false`, or a
//!   bracketed list of them.
//! * `Shape "curve"` with `"point3 P"` (pbrt-v3's `"point P"` too), `"string basis"`
//!   `bezier` (default) or `bspline`, `"integer degree"` 2 or 3 (default 3), `"string type"`
//!   `flat` (default), `ribbon` or `cylinder`, `"float width"` (default 1), `"float width0"`
//!   and `"float width1"` (default `width`), `"normal N"` (required for ribbons: one per
//!   segment end, as pbrt requires; kept in [`Strands::normals`], transformed by the inverse
//!   transpose of the current transformation; ignored for other types, as pbrt does),
//!   `"integer splitdepth"` (ignored). Other parameters of the shape are skipped.
//! * pbrt-v4's control point rules: a Bézier curve of degree `d` has `d·k + 1` points (`k`
//!   segments sharing end points); a B-spline of degree `d` has `n ≥ d + 1` points and `n − d`
//!   segments. Each curve is converted, as pbrt does, to cubic Bézier segments: B-spline
//!   segments by the standard change of basis, quadratic segments by degree elevation. Both
//!   are exact. Each `Shape "curve"` is one strand.
//! * The width runs linearly from `width0` at the start of the curve to `width1` at its end
//!   (pbrt's rule); as Bézier curves reproduce linear functions, the control point `j` of the
//!   `3k + 1` gets `width0 + (width1 − width0)·j/(3k)`.
//! * `Include` and `Import` of `.pbrt` and `.pbrt.gz` files, resolved as pbrt-v4 does:
//!   relative to the directory of the top-level scene file (also for nested includes), at most
//!   [`MAX_INCLUDE_DEPTH`] deep, at most [`MAX_FILES_READ`] files in all and their text within
//!   the memory budget in all ([`crate::memory_budget::input_bound`]); a file that includes
//!   itself through any chain is an error.
//! * The current transformation: `Identity`, `Translate`, `Scale`, `Rotate` (degrees, the file
//!   format's unit), `Transform` and `ConcatTransform` (16 numbers, column by column, as pbrt
//!   reads them), `LookAt`, `CoordinateSystem`/`CoordSysTransform`, saved and restored by
//!   `AttributeBegin`/`AttributeEnd` and `TransformBegin`/`TransformEnd`, and reset by
//!   `WorldBegin`. `ActiveTransform EndTime` blocks do not move the (start-time) points.
//!   Object instancing (`ObjectBegin`/`ObjectEnd`/`ObjectInstance`) places the curves of an
//!   object at each instance.
//! * Points are transformed in `f64` and rounded to `f32`. Widths are multiplied by the
//!   transform's scale, `|det M₃|^{1/3}` of its 3×3 part: exact for a uniform scale, the mean
//!   scale for a non-uniform one (pbrt would deform the cross-section instead).
//!
//! `Attribute "shape"` defaults for the curve parameters read here are refused, not ignored.
//! Every other error — an unknown token, a missing or non-finite number, unbalanced brackets,
//! a wrong point count, mixed curve types in one file, a missing include — names the file, the
//! line and the column and says what was expected.

use crate::lookahead::{Located, Lookahead, Scan};
use crate::scene_text::skip_blanks_and_comments;
use crate::strands::{Basis, CurveKind, Strands, StrandsError, line_column, utf8_text};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How deep `Include`s may nest.
pub const MAX_INCLUDE_DEPTH: usize = 32;

/// How many files one read may open in all, the top-level file and every `Include` (a file
/// included twice counts twice): files that each include the next twice would otherwise make
/// `2^depth` reads within the depth limit.
pub const MAX_FILES_READ: usize = 4096;

/// Reads the curves of the pbrt scene at `path` (and the files it includes).
pub fn read(path: &Path) -> Result<Strands, StrandsError> {
    let mut p = Parser::new(false);
    p.file(path, None, 0)?;
    p.finish()
}

/// Reads the curves of pbrt scene text; `path` names it in errors and is where `Include`s are
/// resolved from.
pub fn parse_str(text: &str, path: &Path) -> Result<Strands, StrandsError> {
    let mut p = Parser::new(false);
    p.files.push(path.to_path_buf());
    p.keys.push(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
    p.text(text, path, 0)?;
    p.finish()
}

/// The bytes of text read and the strands' point counts (no points), from the same parse with
/// the numbers of `P` counted rather than converted.
pub(crate) fn count(path: &Path) -> Result<(u64, Strands), StrandsError> {
    let mut p = Parser::new(true);
    p.file(path, None, 0)?;
    let bytes = p.text_bytes;
    Ok((bytes, p.finish()?))
}

/// The text of a `.pbrt` or `.pbrt.gz` file.
fn load(path: &Path, bound: u64) -> Result<String, StrandsError> {
    let (file, len) = crate::input_file::open(path)?;
    let raw = crate::input_file::read_within(path, file, Some(len), bound)?;
    let bytes = if path.to_string_lossy().to_lowercase().ends_with(".gz") {
        // The decompressed text is bounded like a file's.
        crate::input_file::read_within(path, flate2::read::MultiGzDecoder::new(raw.as_slice()), None, bound)?
    } else {
        raw
    };
    utf8_text(path, bytes)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Word,
    Number,
    Str,
    Open,
    Close,
}

#[derive(Clone, Copy, Debug)]
struct Token<'a> {
    kind: Kind,
    /// The token's text (a string's without its quotes, escapes not yet resolved).
    text: &'a str,
    offset: usize,
}

impl Token<'_> {
    fn describe(&self) -> String {
        match self.kind {
            Kind::Word => format!("the word `{}`", self.text),
            Kind::Number => format!("the number {}", self.text),
            Kind::Str => format!("the string \"{}\"", self.text),
            Kind::Open => "`[`".into(),
            Kind::Close => "`]`".into(),
        }
    }
    fn is_bool(&self) -> bool {
        self.kind == Kind::Word && (self.text == "true" || self.text == "false")
    }
}

/// The tokens of a pbrt file's text.
struct Scanner<'a> {
    text: &'a str,
    pos: usize,
}

type Lexer<'a> = Lookahead<Scanner<'a>>;

/// An error at a byte of the file being parsed, or one already located in an included file.
enum Failure {
    At(usize, String),
    Nested(StrandsError),
}

impl From<Located> for Failure {
    fn from((offset, message): Located) -> Self {
        Self::At(offset, message)
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
        let kind = match c {
            b'[' => {
                self.pos += 1;
                return Ok(Some(Token { kind: Kind::Open, text: "[", offset: start }));
            }
            b']' => {
                self.pos += 1;
                return Ok(Some(Token { kind: Kind::Close, text: "]", offset: start }));
            }
            b'"' => {
                self.pos += 1;
                loop {
                    match b.get(self.pos) {
                        None | Some(b'\n') => {
                            return Err((start, "unterminated string: expected a closing `\"`".into()));
                        }
                        Some(b'\\') => self.pos += 2,
                        Some(b'"') => break,
                        Some(_) => self.pos += 1,
                    }
                }
                self.pos += 1;
                return Ok(Some(Token { kind: Kind::Str, text: &self.text[start + 1..self.pos - 1], offset: start }));
            }
            b'0'..=b'9' | b'-' | b'+' | b'.' => Kind::Number,
            c if c.is_ascii_alphabetic() || c == b'_' => Kind::Word,
            _ => {
                let ch = self.text[start..].chars().next().unwrap_or('?');
                return Err((
                    start,
                    format!(
                        "unexpected character `{}`: expected a directive, a number, a string or `[`",
                        ch.escape_default()
                    ),
                ));
            }
        };
        while self.pos < b.len()
            && !b[self.pos].is_ascii_whitespace()
            && !matches!(b[self.pos], b'[' | b']' | b'"' | b'#')
        {
            self.pos += 1;
        }
        Ok(Some(Token { kind, text: &self.text[start..self.pos], offset: start }))
    }
}

fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c == '\\' {
            match chars.next() {
                Some('n') => out.push('\n'),
                Some('t') => out.push('\t'),
                Some('r') => out.push('\r'),
                Some('b') => out.push('\u{8}'),
                Some('f') => out.push('\u{c}'),
                Some(other) => out.push(other),
                None => {}
            }
        } else {
            out.push(c);
        }
    }
    out
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

fn translate(t: [f64; 3]) -> Mat4 {
    let mut m = IDENTITY;
    (0..3).for_each(|k| m[k][3] = t[k]);
    m
}

fn scale(s: [f64; 3]) -> Mat4 {
    let mut m = IDENTITY;
    (0..3).for_each(|k| m[k][k] = s[k]);
    m
}

/// Rotation by `theta` radians about `axis` (Rodrigues' formula); `None` for a zero axis.
fn rotate(theta: f64, axis: [f64; 3]) -> Option<Mat4> {
    let len = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
    if len == 0.0 {
        return None;
    }
    let a = axis.map(|v| v / len);
    let (s, c) = theta.sin_cos();
    let mut m = IDENTITY;
    let cross = [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = if i == j { c } else { 0.0 } + s * cross[i][j] + (1.0 - c) * a[i] * a[j];
        }
    }
    Some(m)
}

/// pbrt's `LookAt`: camera-from-world of a camera at `eye` looking at `look`.
fn look_at(v: &[f64; 9]) -> Option<Mat4> {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let norm = |a: [f64; 3]| {
        let l = a.iter().map(|x| x * x).sum::<f64>().sqrt();
        (l > 0.0).then(|| a.map(|x| x / l))
    };
    let (eye, look, up) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]], [v[6], v[7], v[8]]);
    let dir = norm(sub(look, eye))?;
    let right = norm(cross(norm(up)?, dir))?;
    let new_up = cross(dir, right);
    // world-from-camera has columns right, up, dir, eye; its inverse is the transposed
    // rotation and the rotated, negated eye.
    let mut m = IDENTITY;
    for (row, axis) in [right, new_up, dir].into_iter().enumerate() {
        m[row][..3].copy_from_slice(&axis);
        m[row][3] = -(0..3).map(|k| axis[k] * eye[k]).sum::<f64>();
    }
    Some(m)
}

/// The 16 numbers of `Transform`/`ConcatTransform`, which pbrt reads column by column.
fn from_columns(v: &[f64]) -> Mat4 {
    let mut m = [[0.0; 4]; 4];
    for (i, &x) in v.iter().enumerate().take(16) {
        m[i % 4][i / 4] = x;
    }
    m
}

fn apply(m: &Mat4, p: [f64; 3]) -> [f64; 3] {
    let h: Vec<f64> = (0..4).map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3]).collect();
    [h[0] / h[3], h[1] / h[3], h[2] / h[3]]
}

/// `|det|^{1/3}` of the 3×3 part: the factor widths are scaled by.
fn width_scale(m: &Mat4) -> f64 {
    let d = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    d.abs().cbrt()
}

/// A normal carried through `m`: by the inverse transpose of its 3×3 part (the cofactor
/// matrix, which is that times `det`; the sign of `det` is kept so that a mirror flips the
/// normal as the inverse transpose does), normalised to unit length.
fn transform_normal(m: &Mat4, n: [f32; 3]) -> [f32; 3] {
    let a = |r: usize, c: usize| m[r][c];
    let n = n.map(f64::from);
    // Cofactor C_rc of the 3×3 part (cyclic indices give the signs); M⁻ᵀ = C / det.
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    let cof = |r: usize, c: usize| {
        let (r0, r1, c0, c1) = ((r + 1) % 3, (r + 2) % 3, (c + 1) % 3, (c + 2) % 3);
        a(r0, c0) * a(r1, c1) - a(r0, c1) * a(r1, c0)
    };
    let out: [f64; 3] = [0, 1, 2].map(|r| det.signum() * (0..3).map(|c| cof(r, c) * n[c]).sum::<f64>());
    let l = (out[0] * out[0] + out[1] * out[1] + out[2] * out[2]).sqrt();
    out.map(|v| (v / l) as f32)
}

/// One value of a parameter list.
struct Param<'a> {
    ty: &'a str,
    name: &'a str,
    values: Vec<Token<'a>>,
    offset: usize,
}

/// The graphics state saved by `AttributeBegin`.
#[derive(Clone, Copy)]
struct State {
    ctm: Mat4,
    active_start: bool,
}

struct Object {
    strands: Strands,
    /// (points start, strands start, normals start) in the output when its definition began.
    start: (usize, usize, usize),
}

struct Parser {
    count_only: bool,
    out: Strands,
    state: State,
    stack: Vec<State>,
    named: HashMap<String, Mat4>,
    objects: HashMap<String, Strands>,
    defining: Option<(String, Object)>,
    /// The include chain, outermost first (for cycle detection and depth).
    files: Vec<PathBuf>,
    /// The type of the first curve, and where it was.
    kind: Option<CurveKind>,
    /// Bytes of text read so far, over all files.
    text_bytes: u64,
    /// Files read so far (see [`MAX_FILES_READ`]).
    files_read: usize,
    /// The canonical paths of `files` (for cycle detection).
    keys: Vec<PathBuf>,
    /// The input bound, read once ([`crate::memory_budget::input_bound`]).
    bound: u64,
}

impl Parser {
    fn new(count_only: bool) -> Self {
        Self {
            count_only,
            out: Strands {
                points: Vec::new(),
                widths: Vec::new(),
                counts: Vec::new(),
                basis: Basis::Bezier,
                kind: CurveKind::Flat,
                normals: Vec::new(),
            },
            state: State { ctm: IDENTITY, active_start: true },
            stack: Vec::new(),
            named: HashMap::new(),
            objects: HashMap::new(),
            defining: None,
            files: Vec::new(),
            kind: None,
            text_bytes: 0,
            files_read: 0,
            keys: Vec::new(),
            bound: crate::memory_budget::input_bound(),
        }
    }

    fn finish(mut self) -> Result<Strands, StrandsError> {
        self.out.kind = self.kind.unwrap_or(CurveKind::Flat);
        Ok(self.out)
    }

    /// Reads and parses the file at `path`; `from` is the including file and the location of
    /// its `Include` (for errors).
    fn file(&mut self, path: &Path, from: Option<(&Path, &str, usize)>, depth: usize) -> Result<(), StrandsError> {
        let at = |message: String| match from {
            Some((p, text, offset)) => {
                let (line, column) = line_column(text, offset);
                StrandsError::Syntax { path: p.into(), line, column, message }
            }
            None => StrandsError::Inconsistent(message),
        };
        if depth > MAX_INCLUDE_DEPTH {
            return Err(at(format!("includes nest more than {MAX_INCLUDE_DEPTH} deep (at {})", path.display())));
        }
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if self.keys.contains(&key) {
            let chain: Vec<String> = self.files.iter().map(|f| f.display().to_string()).collect();
            return Err(at(format!("include cycle: {} → {}", chain.join(" → "), path.display())));
        }
        self.files_read += 1;
        if self.files_read > MAX_FILES_READ {
            return Err(at(format!(
                "more than {MAX_FILES_READ} files read in all (each `Include` reads its file again); \
                 at {}",
                path.display()
            )));
        }
        // All the text read, over every include, stays within the input bound.
        let bound = self.bound.saturating_sub(self.text_bytes);
        let text = match load(path, bound) {
            Ok(t) => t,
            // An included file that cannot be read is an error at its `Include`.
            Err(StrandsError::Input(e)) if from.is_some() => {
                use crate::input_file::InputError;
                return Err(at(match e {
                    InputError::Io { error, .. } => {
                        format!("cannot read the included file {}: {error}", path.display())
                    }
                    InputError::TooLarge { .. } => format!(
                        "the included files come to more than the memory budget ({}) in all, at {}",
                        crate::memory_budget::budget().describe(),
                        path.display()
                    ),
                    other => format!("cannot read the included file: {other}"),
                }));
            }
            Err(e) => return Err(e),
        };
        self.text_bytes += text.len() as u64;
        self.files.push(path.to_path_buf());
        self.keys.push(key);
        self.text(&text, path, depth)?;
        self.files.pop();
        self.keys.pop();
        Ok(())
    }

    fn text(&mut self, text: &str, path: &Path, depth: usize) -> Result<(), StrandsError> {
        let mut lx = Lexer::new(Scanner { text, pos: 0 });
        self.directives(&mut lx, path, depth).map_err(|f| match f {
            Failure::At(offset, message) => {
                let (line, column) = line_column(text, offset);
                StrandsError::Syntax { path: path.into(), line, column, message }
            }
            Failure::Nested(e) => e,
        })
    }

    fn directives(&mut self, lx: &mut Lexer<'_>, path: &Path, depth: usize) -> Result<(), Failure> {
        let attribute_depth = self.stack.len();
        while let Some(t) = lx.next()? {
            if t.kind != Kind::Word || t.is_bool() {
                return Err(Failure::from((
                    t.offset,
                    format!("expected a directive (a word such as Shape or AttributeBegin), found {}", t.describe()),
                )));
            }
            match t.text {
                "AttributeBegin" | "TransformBegin" => self.stack.push(self.state),
                "AttributeEnd" | "TransformEnd" => {
                    if self.stack.len() <= attribute_depth {
                        return Err(Failure::from((
                            t.offset,
                            format!("{} without a matching begin in this file", t.text),
                        )));
                    }
                    self.state = self.stack.pop().expect("checked");
                }
                "Identity" => self.set(IDENTITY),
                "WorldBegin" => {
                    self.state.ctm = IDENTITY;
                    self.named.insert("world".into(), IDENTITY);
                }
                "Translate" => {
                    let v = numbers(lx, 3, t)?;
                    self.concat(translate([v[0], v[1], v[2]]));
                }
                "Scale" => {
                    let v = numbers(lx, 3, t)?;
                    self.concat(scale([v[0], v[1], v[2]]));
                }
                "Rotate" => {
                    let v = numbers(lx, 4, t)?;
                    let m = rotate(v[0].to_radians(), [v[1], v[2], v[3]])
                        .ok_or((t.offset, "Rotate: the axis is zero; expected a non-zero axis".to_string()))?;
                    self.concat(m);
                }
                "LookAt" => {
                    let v = numbers(lx, 9, t)?;
                    let m = look_at(&v.try_into().expect("9 numbers"))
                        .ok_or((t.offset, "LookAt: the eye, target and up vector are degenerate".to_string()))?;
                    self.concat(m);
                }
                "Transform" | "ConcatTransform" => {
                    let v = bracketed_numbers(lx, 16, t)?;
                    let m = from_columns(&v);
                    if t.text == "Transform" { self.set(m) } else { self.concat(m) }
                }
                "CoordinateSystem" => {
                    let name = string(lx, t)?;
                    self.named.insert(unescape(name.text), self.state.ctm);
                }
                "CoordSysTransform" => {
                    let name = string(lx, t)?;
                    let m = *self.named.get(&unescape(name.text)).ok_or((
                        name.offset,
                        format!("CoordSysTransform: no coordinate system named \"{}\" was defined", name.text),
                    ))?;
                    self.set(m);
                }
                "ActiveTransform" => {
                    let which = lx
                        .next()?
                        .filter(|w| w.kind == Kind::Word)
                        .ok_or((t.offset, "ActiveTransform: expected StartTime, EndTime or All".to_string()))?;
                    self.state.active_start = match which.text {
                        "StartTime" | "All" => true,
                        "EndTime" => false,
                        other => {
                            return Err(Failure::from((
                                which.offset,
                                format!("ActiveTransform: expected StartTime, EndTime or All, found `{other}`"),
                            )));
                        }
                    };
                }
                "Include" | "Import" => {
                    let name = string(lx, t)?;
                    let rel = PathBuf::from(unescape(name.text));
                    // pbrt-v4 resolves every relative name against the directory of the scene
                    // file it was started on, however deep the include.
                    let root = self.files.first().map_or(path, PathBuf::as_path);
                    let target = root.parent().map_or(rel.clone(), |d| d.join(&rel));
                    // Errors inside the included file name it; errors opening it name this one.
                    let text = lx.scanner.text;
                    self.file(&target, Some((path, text, name.offset)), depth + 1).map_err(Failure::Nested)?;
                }
                "ObjectBegin" => {
                    let name = string(lx, t)?;
                    if self.defining.is_some() {
                        return Err(Failure::from((t.offset, "ObjectBegin inside another object definition".into())));
                    }
                    self.stack.push(self.state);
                    let start = (self.out.points.len(), self.out.counts.len(), self.out.normals.len());
                    let empty = Strands {
                        points: Vec::new(),
                        widths: Vec::new(),
                        counts: Vec::new(),
                        basis: Basis::Bezier,
                        kind: CurveKind::Flat,
                        normals: Vec::new(),
                    };
                    self.defining = Some((unescape(name.text), Object { strands: empty, start }));
                }
                "ObjectEnd" => {
                    let (name, mut object) =
                        self.defining.take().ok_or((t.offset, "ObjectEnd without ObjectBegin".to_string()))?;
                    let (p, s, n) = object.start;
                    object.strands.points = self.out.points.split_off(p);
                    object.strands.widths = self.out.widths.split_off(p);
                    object.strands.counts = self.out.counts.split_off(s);
                    object.strands.normals = self.out.normals.split_off(n);
                    self.objects.insert(name, object.strands);
                    if self.stack.len() <= attribute_depth {
                        return Err(Failure::from((
                            t.offset,
                            "ObjectEnd without a matching ObjectBegin in this file".into(),
                        )));
                    }
                    self.state = self.stack.pop().expect("checked");
                }
                "ObjectInstance" => {
                    let name = string(lx, t)?;
                    let object = self.objects.get(&unescape(name.text)).ok_or((
                        name.offset,
                        format!("ObjectInstance: no object named \"{}\" was defined before", name.text),
                    ))?;
                    // Instances of instances multiply the points: each copy is checked
                    // against the memory budget before it is made (16 bytes per point).
                    let points_after = (self.out.points.len() as u64).saturating_add(object.points.len() as u64);
                    if let Err(e) = crate::memory_budget::check_needs(&[crate::memory_budget::Need::items(
                        format!("ObjectInstance \"{}\": {points_after} curve points", name.text),
                        points_after,
                        16,
                    )]) {
                        return Err(Failure::from((t.offset, e.to_string())));
                    }
                    let m = self.state.ctm;
                    let ws = width_scale(&m);
                    if !(object.points.is_empty() || ws > 0.0 && ws.is_finite()) {
                        return Err(Failure::from((
                            t.offset,
                            "ObjectInstance: the current transform is singular (a scale of 0 along some axis); the \
                             instance's curves would have no width"
                                .to_string(),
                        )));
                    }
                    let points: Vec<[f32; 3]> =
                        object.points.iter().map(|p| apply(&m, p.map(f64::from)).map(|v| v as f32)).collect();
                    if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
                        return Err(Failure::from((
                            t.offset,
                            format!("ObjectInstance: instance point {i} is not finite after the transform"),
                        )));
                    }
                    let widths: Vec<f32> = object.widths.iter().map(|&w| (f64::from(w) * ws) as f32).collect();
                    let counts = object.counts.clone();
                    let normals: Vec<[f32; 3]> = object.normals.iter().map(|n| transform_normal(&m, *n)).collect();
                    self.out.points.extend(points);
                    self.out.widths.extend(widths);
                    self.out.counts.extend(counts);
                    self.out.normals.extend(normals);
                }
                "Shape" => {
                    let name = string(lx, t)?;
                    let params = param_list(lx)?;
                    if name.text == "curve" {
                        self.curve(t, &params)?;
                    }
                }
                "Attribute" => {
                    let target = string(lx, t)?;
                    let params = param_list(lx)?;
                    if target.text == "shape"
                        && let Some(p) = params.iter().find(|p| CURVE_PARAMS.contains(&p.name))
                    {
                        return Err(Failure::from((
                            p.offset,
                            format!(
                                "Attribute \"shape\" sets a default for the curve parameter \"{}\"; write it on each Shape \"curve\" instead",
                                p.name
                            ),
                        )));
                    }
                }
                _ => skip_arguments(lx)?,
            }
        }
        if self.stack.len() > attribute_depth {
            return Err(Failure::from((
                lx.scanner.text.len(),
                "end of file inside an AttributeBegin (expected AttributeEnd)".into(),
            )));
        }
        Ok(())
    }

    fn set(&mut self, m: Mat4) {
        if self.state.active_start {
            self.state.ctm = m;
        }
    }

    fn concat(&mut self, m: Mat4) {
        if self.state.active_start {
            self.state.ctm = mul(&self.state.ctm, &m);
        }
    }

    /// `Shape "curve"` (module docs).
    fn curve<'a>(&mut self, shape: Token<'a>, params: &[Param<'a>]) -> Result<(), Failure> {
        let find = |name: &str, types: &[&str]| -> Result<Option<&Param<'a>>, Located> {
            match params.iter().rev().find(|p| p.name == name) {
                Some(p) if !types.contains(&p.ty) => Err((
                    p.offset,
                    format!(
                        "curve parameter \"{name}\" must be of type {}, found \"{} {name}\"",
                        types.join(" or "),
                        p.ty
                    ),
                )),
                other => Ok(other),
            }
        };
        let one = |p: &Param<'a>| -> Result<Token<'a>, Located> {
            match p.values.as_slice() {
                [v] => Ok(*v),
                _ => Err((
                    p.offset,
                    format!("curve parameter \"{}\": expected one value, found {}", p.name, p.values.len()),
                )),
            }
        };
        let string_of = |name: &str, default: &'static str| -> Result<(String, usize), Located> {
            match find(name, &["string"])? {
                Some(p) => {
                    let v = one(p)?;
                    if v.kind != Kind::Str {
                        return Err((
                            v.offset,
                            format!("\"string {name}\": expected a quoted string, found {}", v.describe()),
                        ));
                    }
                    Ok((unescape(v.text), v.offset))
                }
                None => Ok((default.into(), shape.offset)),
            }
        };
        let float_of = |name: &str, types: &[&str], default: f64| -> Result<f64, Located> {
            match find(name, types)? {
                Some(p) => number(one(p)?),
                None => Ok(default),
            }
        };
        let degree = float_of("degree", &["integer"], 3.0)?;
        if degree != 2.0 && degree != 3.0 {
            let at = find("degree", &["integer"])?.map_or(shape.offset, |p| p.offset);
            return Err(Failure::from((at, format!("curve \"integer degree\" must be 2 or 3, found {degree}"))));
        }
        let degree = degree as usize;
        let (basis, basis_at) = string_of("basis", "bezier")?;
        let bspline = match basis.as_str() {
            "bezier" => false,
            "bspline" => true,
            other => {
                return Err(Failure::from((
                    basis_at,
                    format!("curve \"string basis\" must be \"bezier\" or \"bspline\", found \"{other}\""),
                )));
            }
        };
        let (ty, ty_at) = string_of("type", "flat")?;
        let kind = match ty.as_str() {
            "flat" => CurveKind::Flat,
            "ribbon" => CurveKind::Ribbon,
            "cylinder" => CurveKind::Cylinder,
            other => {
                return Err(Failure::from((
                    ty_at,
                    format!("curve \"string type\" must be \"flat\", \"ribbon\" or \"cylinder\", found \"{other}\""),
                )));
            }
        };
        match self.kind {
            None => self.kind = Some(kind),
            Some(k) if k != kind => {
                return Err(Failure::from((
                    ty_at,
                    format!(
                        "curve type \"{kind}\" differs from the earlier curves' \"{k}\"; fiberlab reads one curve type per file"
                    ),
                )));
            }
            Some(_) => {}
        }
        let width = float_of("width", &["float"], 1.0)?;
        let width0 = float_of("width0", &["float"], width)?;
        let width1 = float_of("width1", &["float"], width)?;
        for (name, w) in [("width", width), ("width0", width0), ("width1", width1)] {
            if w < 0.0 {
                return Err(Failure::from((
                    shape.offset,
                    format!("curve \"float {name}\" = {w} is negative; a width is a diameter ≥ 0"),
                )));
            }
        }
        let p = find("P", &["point3", "point"])?
            .ok_or((shape.offset, "Shape \"curve\" needs \"point3 P\" (its control points)".to_string()))?;
        if p.values.len() % 3 != 0 {
            return Err(Failure::from((
                p.offset,
                format!("\"point3 P\" has {} numbers, not a multiple of 3", p.values.len()),
            )));
        }
        let n = p.values.len() / 3;
        let segments = if bspline {
            if n < degree + 1 {
                return Err(Failure::from((
                    p.offset,
                    format!("a degree-{degree} B-spline curve needs at least {} control points, found {n}", degree + 1),
                )));
            }
            n - degree
        } else {
            if n < degree + 1 || (n - 1) % degree != 0 {
                return Err(Failure::from((
                    p.offset,
                    format!("a degree-{degree} Bézier curve needs {degree}k + 1 control points (k ≥ 1), found {n}"),
                )));
            }
            (n - 1) / degree
        };
        let mut ribbon_normals = Vec::new();
        if let Some(normals) = find("N", &["normal", "normal3"])? {
            if kind == CurveKind::Ribbon {
                if normals.values.len() != 3 * (segments + 1) {
                    return Err(Failure::from((
                        normals.offset,
                        format!(
                            "a ribbon curve of {segments} segments needs {} normals \"N\", found {} numbers",
                            segments + 1,
                            normals.values.len()
                        ),
                    )));
                }
                for (j, c) in normals.values.chunks_exact(3).enumerate() {
                    let n = [number(c[0])?, number(c[1])?, number(c[2])?];
                    if n == [0.0; 3] {
                        return Err(Failure::from((
                            c[0].offset,
                            format!("ribbon normal {j} is (0, 0, 0); a normal orients the ribbon and must be non-zero"),
                        )));
                    }
                    ribbon_normals.push(n);
                }
            }
        } else if kind == CurveKind::Ribbon {
            return Err(Failure::from((
                shape.offset,
                "a \"ribbon\" curve needs \"normal N\" at its segment ends".into(),
            )));
        }
        if let Some(sd) = find("splitdepth", &["integer"])? {
            number(one(sd)?)?;
        }
        let cubic_points = 3 * segments + 1;
        self.out.counts.push(
            u32::try_from(cubic_points).map_err(|_| (p.offset, "too many control points in one curve".to_string()))?,
        );
        if self.count_only {
            if let Some(bad) = p.values.iter().find(|v| v.kind != Kind::Number) {
                return Err(Failure::from((
                    bad.offset,
                    format!("\"point3 P\": expected a number, found {}", bad.describe()),
                )));
            }
            return Ok(());
        }
        let mut cp = Vec::with_capacity(n);
        for c in p.values.chunks_exact(3) {
            cp.push([number(c[0])?, number(c[1])?, number(c[2])?]);
        }
        let bezier = to_cubic_bezier(&cp, degree, bspline);
        let m = self.state.ctm;
        let ws = width_scale(&m);
        if !(ws > 0.0 && ws.is_finite()) {
            // A zero scale flattens the curve and makes its width 0 (a width of 0 itself is
            // refused by the scene's diameter check): refused here, where the curve is.
            return Err(Failure::from((
                p.offset,
                format!(
                    "the current transform is singular (a scale of 0 along some axis: |det| = {:e}); its curves \
                     would have no width",
                    ws.powi(3)
                ),
            )));
        }
        let last = (bezier.len() - 1) as f64;
        for (j, c) in bezier.iter().enumerate() {
            let q = apply(&m, *c).map(|v| v as f32);
            if !q.iter().all(|v| v.is_finite()) {
                return Err(Failure::from((
                    p.offset,
                    format!("control point {j} is not finite after the transform ({q:?})"),
                )));
            }
            self.out.points.push(q);
            let w = width0 + (width1 - width0) * (j as f64 / last);
            self.out.widths.push((w * ws) as f32);
        }
        for n in ribbon_normals {
            self.out.normals.push(transform_normal(&m, n.map(|v| v as f32)));
        }
        Ok(())
    }
}

/// The parameter names of `Shape "curve"` this reader honours.
const CURVE_PARAMS: [&str; 9] = ["P", "basis", "degree", "type", "width", "width0", "width1", "N", "splitdepth"];

/// A curve's control points as cubic Bézier control points `3k + 1` (module docs).
fn to_cubic_bezier(cp: &[[f64; 3]], degree: usize, bspline: bool) -> Vec<[f64; 3]> {
    let lerp = |a: [f64; 3], b: [f64; 3], t: f64| {
        [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
    };
    let comb = |w: [f64; 4], p: [&[f64; 3]; 4]| -> [f64; 3] {
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            *o = w[0] * p[0][k] + w[1] * p[1][k] + w[2] * p[2][k] + w[3] * p[3][k];
        }
        out
    };
    // Segments as cubic Bézier (4 points each).
    let mut segs: Vec<[[f64; 3]; 4]> = Vec::new();
    match (degree, bspline) {
        (3, false) => {
            for k in 0..(cp.len() - 1) / 3 {
                segs.push([cp[3 * k], cp[3 * k + 1], cp[3 * k + 2], cp[3 * k + 3]]);
            }
        }
        (3, true) => {
            for k in 0..cp.len() - 3 {
                let p = [&cp[k], &cp[k + 1], &cp[k + 2], &cp[k + 3]];
                segs.push([
                    comb([1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0, 0.0], p),
                    comb([0.0, 2.0 / 3.0, 1.0 / 3.0, 0.0], p),
                    comb([0.0, 1.0 / 3.0, 2.0 / 3.0, 0.0], p),
                    comb([0.0, 1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0], p),
                ]);
            }
        }
        _ => {
            // Quadratic: as quadratic Bézier (q0, q1, q2), then raised to cubic.
            let quads: Vec<[[f64; 3]; 3]> = if bspline {
                (0..cp.len() - 2)
                    .map(|k| [lerp(cp[k], cp[k + 1], 0.5), cp[k + 1], lerp(cp[k + 1], cp[k + 2], 0.5)])
                    .collect()
            } else {
                (0..(cp.len() - 1) / 2).map(|k| [cp[2 * k], cp[2 * k + 1], cp[2 * k + 2]]).collect()
            };
            for [q0, q1, q2] in quads {
                segs.push([q0, lerp(q0, q1, 2.0 / 3.0), lerp(q2, q1, 2.0 / 3.0), q2]);
            }
        }
    }
    let mut out = Vec::with_capacity(3 * segs.len() + 1);
    for (i, s) in segs.iter().enumerate() {
        out.extend_from_slice(if i == 0 { &s[..] } else { &s[1..] });
    }
    out
}

fn number(t: Token<'_>) -> Result<f64, Located> {
    if t.kind != Kind::Number {
        return Err((t.offset, format!("expected a number, found {}", t.describe())));
    }
    match t.text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err((t.offset, format!("the number {} is not finite ({v})", t.text))),
        Err(_) => Err((t.offset, format!("`{}` is not a number", t.text))),
    }
}

fn string<'a>(lx: &mut Lexer<'a>, directive: Token<'_>) -> Result<Token<'a>, Located> {
    match lx.next()? {
        Some(t) if t.kind == Kind::Str => Ok(t),
        Some(t) => Err((t.offset, format!("{}: expected a quoted name, found {}", directive.text, t.describe()))),
        None => Err((
            lx.scanner.text.len(),
            format!("{}: expected a quoted name, found the end of the file", directive.text),
        )),
    }
}

fn numbers(lx: &mut Lexer<'_>, n: usize, directive: Token<'_>) -> Result<Vec<f64>, Located> {
    (0..n)
        .map(|i| match lx.next()? {
            Some(t) if t.kind == Kind::Number => number(t),
            other => {
                let (at, found) = other
                    .map_or((lx.scanner.text.len(), "the end of the file".to_string()), |t| (t.offset, t.describe()));
                Err((at, format!("{}: expected {n} numbers, found {found} as number {}", directive.text, i + 1)))
            }
        })
        .collect()
}

fn bracketed_numbers(lx: &mut Lexer<'_>, n: usize, directive: Token<'_>) -> Result<Vec<f64>, Located> {
    let open = lx.peek()?.is_some_and(|t| t.kind == Kind::Open);
    if open {
        lx.next()?;
    }
    let v = numbers(lx, n, directive)?;
    if open {
        match lx.next()? {
            Some(t) if t.kind == Kind::Close => {}
            other => {
                let (at, found) = other
                    .map_or((lx.scanner.text.len(), "the end of the file".to_string()), |t| (t.offset, t.describe()));
                return Err((at, format!("{}: expected `]` after {n} numbers, found {found}", directive.text)));
            }
        }
    }
    Ok(v)
}

/// A value: one token, or a bracketed list (no nesting).
fn value<'a>(lx: &mut Lexer<'a>, decl: Token<'_>) -> Result<Vec<Token<'a>>, Located> {
    let is_value = |t: &Token<'_>| matches!(t.kind, Kind::Number | Kind::Str) || t.is_bool();
    match lx.next()? {
        Some(t) if t.kind == Kind::Open => {
            let mut out = Vec::new();
            loop {
                match lx.next()? {
                    Some(v) if is_value(&v) => out.push(v),
                    Some(c) if c.kind == Kind::Close => return Ok(out),
                    Some(v) => {
                        return Err((
                            v.offset,
                            format!(
                                "inside the `[` opened at this list: expected a value or `]`, found {}",
                                v.describe()
                            ),
                        ));
                    }
                    None => {
                        return Err((
                            t.offset,
                            "this `[` is never closed (expected `]` before the end of the file)".into(),
                        ));
                    }
                }
            }
        }
        Some(t) if is_value(&t) => Ok(vec![t]),
        Some(t) => {
            Err((t.offset, format!("parameter \"{}\": expected a value or `[`, found {}", decl.text, t.describe())))
        }
        None => Err((
            lx.scanner.text.len(),
            format!("parameter \"{}\": expected a value, found the end of the file", decl.text),
        )),
    }
}

/// `"type name" value …` until the next directive.
fn param_list<'a>(lx: &mut Lexer<'a>) -> Result<Vec<Param<'a>>, Located> {
    let mut out = Vec::new();
    while let Some(t) = lx.peek()? {
        match t.kind {
            Kind::Str => {
                lx.next()?;
                let mut parts = t.text.split_whitespace();
                let (Some(ty), Some(name), None) = (parts.next(), parts.next(), parts.next()) else {
                    return Err((
                        t.offset,
                        format!("expected a parameter declaration \"type name\", found \"{}\"", t.text),
                    ));
                };
                let values = value(lx, t)?;
                out.push(Param { ty, name, values, offset: t.offset });
            }
            Kind::Word if !t.is_bool() => break,
            _ => {
                return Err((
                    t.offset,
                    format!("expected a parameter \"type name\" or the next directive, found {}", t.describe()),
                ));
            }
        }
    }
    Ok(out)
}

/// Skips the arguments of a directive this reader does not interpret: numbers, strings and
/// bracketed lists, up to the next directive.
fn skip_arguments(lx: &mut Lexer<'_>) -> Result<(), Located> {
    while let Some(t) = lx.peek()? {
        match t.kind {
            Kind::Word if !t.is_bool() => break,
            Kind::Open => {
                let decl = Token { kind: Kind::Str, text: "", offset: t.offset };
                value(lx, decl)?;
            }
            Kind::Close => return Err((t.offset, "`]` without a matching `[`".into())),
            _ => {
                lx.next()?;
            }
        }
    }
    Ok(())
}
